#include "analysis/core/sincos.h"

#include "analysis/core/cpu.h"

#if KM_SINCOS_AVX2
#include <immintrin.h>

namespace km::internal {

namespace {

// Horner from the last coefficient of `coef` (sincos.h): k + z·p at each step, a product then a
// sum.
__attribute__((target("avx2"))) inline __m256d Horner(__m256d z, const double* coef) {
  __m256d p = _mm256_set1_pd(coef[5]);
  for (int k = 4; k >= 0; --k) p = _mm256_add_pd(_mm256_set1_pd(coef[k]), _mm256_mul_pd(z, p));
  return p;
}

// SinCos2 (sincos.h) on four lanes, operation for operation (no fused multiply-add).
__attribute__((target("avx2"))) void SinCos4(__m256d x, __m256d* s, __m256d* c) {
  const __m256d qd = _mm256_mul_pd(x, _mm256_set1_pd(kTwoOverPi));
  const __m128i qi = _mm256_cvtpd_epi32(qd);  // round to nearest, ties to even: std::rint
  const __m256d q = _mm256_cvtepi32_pd(qi);
  __m256d r = x;
  for (const double part : kPio2Parts) r = _mm256_sub_pd(r, _mm256_mul_pd(q, _mm256_set1_pd(part)));
  const __m256d z = _mm256_mul_pd(r, r);
  const __m256d sr = _mm256_add_pd(r, _mm256_mul_pd(_mm256_mul_pd(z, r), Horner(z, kSinCoef)));
  const __m256d pc = _mm256_mul_pd(z, Horner(z, kCosCoef));
  const __m256d hz = _mm256_mul_pd(_mm256_set1_pd(0.5), z);
  const __m256d w = _mm256_sub_pd(_mm256_set1_pd(1.0), hz);
  const __m256d cr =
      _mm256_add_pd(w, _mm256_add_pd(_mm256_sub_pd(_mm256_sub_pd(_mm256_set1_pd(1.0), w), hz),
                                     _mm256_mul_pd(z, pc)));
  // Quadrant k = q mod 4 per lane (widened to 64 bits for the lane masks).
  const __m256i k = _mm256_cvtepi32_epi64(_mm_and_si128(qi, _mm_set1_epi32(3)));
  const __m256i one = _mm256_set1_epi64x(1), two = _mm256_set1_epi64x(2);
  const __m256d odd = _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(k, one), one));
  const __m256d sin_neg = _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(k, two), two));
  const __m256i k1 = _mm256_add_epi64(k, one);
  const __m256d cos_neg = _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(k1, two), two));
  const __m256d sign = _mm256_set1_pd(-0.0);
  const __m256d sv = _mm256_blendv_pd(sr, cr, odd);
  const __m256d cv = _mm256_blendv_pd(cr, sr, odd);
  *s = _mm256_xor_pd(sv, _mm256_and_pd(sin_neg, sign));
  *c = _mm256_xor_pd(cv, _mm256_and_pd(cos_neg, sign));
}

__attribute__((target("avx2"))) bool InRange4(const double* x) {
  const __m256d a = _mm256_andnot_pd(_mm256_set1_pd(-0.0), _mm256_loadu_pd(x));
  // |x| ≤ 1e5, false for NaN (ordered comparison).
  return _mm256_movemask_pd(_mm256_cmp_pd(a, _mm256_set1_pd(1e5), _CMP_LE_OQ)) == 0xF;
}

}  // namespace

bool SinCosHasAvx2() {
  return CpuHasAvx2();
}

__attribute__((target("avx2"))) void SinCosArrayAvx2(const double* x, double* s, double* c,
                                                     std::size_t n) {
  std::size_t i = 0;
  for (; i + 3 < n; i += 4) {
    if (!InRange4(x + i)) {
      for (std::size_t j = i; j < i + 4; ++j) SinCos(x[j], s + j, c + j);
      continue;
    }
    __m256d sv, cv;
    SinCos4(_mm256_loadu_pd(x + i), &sv, &cv);
    _mm256_storeu_pd(s + i, sv);
    _mm256_storeu_pd(c + i, cv);
  }
  for (; i < n; ++i) SinCos(x[i], s + i, c + i);
}

}  // namespace km::internal

#endif
