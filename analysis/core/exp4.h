// Eigen 3.4's exponential and logarithm of SSE2 packets (the logarithm below) (pexp_double,
// GenericPacketMathFunctions.h) on four lanes with AVX2, operation for operation, so bit for bit
// what Eigen's `.exp()` of an array gives on this build: its clamp to ±709.784, Cephes' rational
// approximation (no fused multiply-add: Eigen's SSE2 pmadd is a product then a sum), the scaling by
// 2^n in four factors as its SSE2 pldexp does (subnormal and vanishing results round as there), and
// min and max with Eigen's order of arguments (which decides what a NaN gives). Callers check
// CpuHasAvx2() (analysis/core/cpu.h) before calling.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

#include <Eigen/Core>  // EIGEN_LN2

#define KM_EXP4_AVX2 1

namespace km {

namespace exp4 {

__attribute__((target("avx2"))) inline __m256d Set(double v) {
  return _mm256_set1_pd(v);
}

__attribute__((target("avx2"))) inline __m256d Bits(long long b) {
  return _mm256_castsi256_pd(_mm256_set1_epi64x(b));
}

// a·b + c as Eigen's SSE2 pmadd: a product, then a sum.
__attribute__((target("avx2"))) inline __m256d Madd(__m256d a, __m256d b, __m256d c) {
  return _mm256_add_pd(_mm256_mul_pd(a, b), c);
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

// Eigen 3.4's logarithm of SSE2 packets (plog_double with its pfrexp) on four lanes, operation
// for operation: the argument raised to the smallest normal first (so no lane is subnormal in
// the split into mantissa and exponent), Cephes' rational approximation, and Eigen's results
// for 0 (−∞), +∞ (+∞), negative arguments and NaN (NaN).
__attribute__((target("avx2"))) inline __m256d Log4(__m256d x0) {
  using exp4::Bits;
  using exp4::Madd;
  using exp4::Set;
  const __m256d one = Set(1.0), zero = _mm256_setzero_pd();
  __m256d x = _mm256_max_pd(Bits(0x0010000000000000LL), x0);
  // pfrexp: the mantissa in [0.5, 1) and the exponent (0 for zero, ∞ and NaN).
  const __m256i biased =
      _mm256_srli_epi64(_mm256_castpd_si256(_mm256_and_pd(x, Bits(0x7ff0000000000000LL))), 52);
  const __m128i low = _mm256_castsi256_si128(
      _mm256_permutevar8x32_epi32(biased, _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0)));
  const __m256d exponent = _mm256_cvtepi32_pd(low);
  const __m256d special = _mm256_or_pd(_mm256_cmp_pd(x, zero, _CMP_EQ_OQ),
                                       _mm256_cmp_pd(exponent, Set(2047.0), _CMP_EQ_OQ));
  const __m256d mantissa = _mm256_or_pd(
      _mm256_and_pd(x, Bits(static_cast<long long>(~0x7ff0000000000000ULL))), Set(0.5));
  x = _mm256_blendv_pd(mantissa, x, special);
  __m256d e = _mm256_blendv_pd(_mm256_add_pd(exponent, Set(-1022.0)), zero, special);
  // Into [√½, √2) less 1.
  const __m256d mask = _mm256_cmp_pd(x, Set(0.70710678118654752440E0), _CMP_LT_OS);
  const __m256d tmp = _mm256_and_pd(x, mask);
  x = _mm256_sub_pd(x, one);
  e = _mm256_sub_pd(e, _mm256_and_pd(one, mask));
  x = _mm256_add_pd(x, tmp);
  const __m256d x2 = _mm256_mul_pd(x, x), x3 = _mm256_mul_pd(x2, x);
  __m256d y = Madd(Set(1.01875663804580931796E-4), x, Set(4.97494994976747001425E-1));
  __m256d y1 = Madd(Set(1.44989225341610930846E1), x, Set(1.79368678507819816313E1));
  y = Madd(y, x, Set(4.70579119878881725854E0));
  y1 = Madd(y1, x, Set(7.70838733755885391666E0));
  __m256d num = Madd(y, x3, y1);
  y = Madd(Set(1.0), x, Set(1.12873587189167450590E1));
  y1 = Madd(Set(8.29875266912776603211E1), x, Set(7.11544750618563894466E1));
  y = Madd(y, x, Set(4.52279145837532221105E1));
  y1 = Madd(y1, x, Set(2.31251620126765340583E1));
  y = Madd(y, x3, y1);
  num = _mm256_mul_pd(num, x3);
  y = _mm256_div_pd(num, y);
  y = Madd(Set(-0.5), x2, y);
  x = _mm256_add_pd(x, y);
  x = Madd(e, Set(static_cast<double>(EIGEN_LN2)), x);
  const __m256d invalid = _mm256_cmp_pd(x0, zero, _CMP_NGE_UQ);
  const __m256d is_zero = _mm256_cmp_pd(x0, zero, _CMP_EQ_OQ);
  const __m256d inf = Bits(0x7ff0000000000000LL);
  const __m256d is_inf = _mm256_cmp_pd(x0, inf, _CMP_EQ_OQ);
  return _mm256_blendv_pd(_mm256_or_pd(_mm256_blendv_pd(x, inf, is_inf), invalid),
                          Bits(static_cast<long long>(0xfff0000000000000ULL)), is_zero);
}

}  // namespace km

#endif
