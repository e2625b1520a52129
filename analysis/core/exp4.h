// Eigen 3.4's exponential of SSE2 packets (pexp_double, GenericPacketMathFunctions.h) on four
// lanes with AVX2, operation for operation, so bit for bit what Eigen's `.exp()` of an array
// gives on this build: its clamp to ±709.784, Cephes' rational approximation (no fused
// multiply-add: Eigen's SSE2 pmadd is a product then a sum), the scaling by 2^n in four
// factors as its SSE2 pldexp does (subnormal and vanishing results round as there), and min
// and max with Eigen's order of arguments (which decides what a NaN gives). Callers check
// __builtin_cpu_supports("avx2") before calling.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

#define KM_EXP4_AVX2 1

namespace km {

namespace exp4 {

__attribute__((target("avx2"))) inline __m256d Set(double v) {
  return _mm256_set1_pd(v);
}

// a · 2^e for integral e: e clamped to ±2099, 2^e applied in four factors.
__attribute__((target("avx2"))) inline __m256d Ldexp(__m256d a, __m256d exponent) {
  const __m256d e = _mm256_min_pd(Set(2099.0), _mm256_max_pd(Set(-2099.0), exponent));
  const __m128i ei = _mm256_cvtpd_epi32(e);
  const __m128i b = _mm_srai_epi32(ei, 2);  // floor(e/4)
  const __m256i bias = _mm256_set1_epi64x(1023);
  const __m256d c =
      _mm256_castsi256_pd(_mm256_slli_epi64(_mm256_add_epi64(_mm256_cvtepi32_epi64(b), bias), 52));
  const __m256d out = _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(a, c), c), c);
  const __m128i rest = _mm_sub_epi32(_mm_sub_epi32(_mm_sub_epi32(ei, b), b), b);
  const __m256d c2 = _mm256_castsi256_pd(
      _mm256_slli_epi64(_mm256_add_epi64(_mm256_cvtepi32_epi64(rest), bias), 52));
  return _mm256_mul_pd(out, c2);
}

}  // namespace exp4

__attribute__((target("avx2"))) inline __m256d Exp4(__m256d x0) {
  using exp4::Set;
  __m256d x = _mm256_max_pd(Set(-709.784), _mm256_min_pd(Set(709.784), x0));
  const __m256d fx =
      _mm256_floor_pd(_mm256_add_pd(_mm256_mul_pd(Set(1.4426950408889634073599), x), Set(0.5)));
  x = _mm256_sub_pd(x, _mm256_mul_pd(fx, Set(0.693145751953125)));
  x = _mm256_sub_pd(x, _mm256_mul_pd(fx, Set(1.42860682030941723212e-6)));
  const __m256d x2 = _mm256_mul_pd(x, x);
  __m256d px = _mm256_add_pd(_mm256_mul_pd(Set(1.26177193074810590878e-4), x2),
                             Set(3.02994407707441961300e-2));
  px = _mm256_add_pd(_mm256_mul_pd(px, x2), Set(9.99999999999999999910e-1));
  px = _mm256_mul_pd(px, x);
  __m256d qx = _mm256_add_pd(_mm256_mul_pd(Set(3.00198505138664455042e-6), x2),
                             Set(2.52448340349684104192e-3));
  qx = _mm256_add_pd(_mm256_mul_pd(qx, x2), Set(2.27265548208155028766e-1));
  qx = _mm256_add_pd(_mm256_mul_pd(qx, x2), Set(2.00000000000000000009e0));
  x = _mm256_div_pd(px, _mm256_sub_pd(qx, px));
  x = _mm256_add_pd(_mm256_mul_pd(Set(2.0), x), Set(1.0));
  return _mm256_max_pd(x0, exp4::Ldexp(x, fx));
}

}  // namespace km

#endif
