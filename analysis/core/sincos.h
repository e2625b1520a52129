// SinCos: sine and cosine of one angle together, for the hot loops of the analyses (the cyclic
// error signatures and their period search evaluate one per sample and period tried). Range
// reduction by multiples of π/2 in three parts (Cody and Waite), then the minimax polynomials
// of fdlibm's sine and cosine kernels on [−π/4, π/4]; within 1 ulp-ish (|error| ≤ 2.3e-16 · max(1,
// |result|) in the tests) of the correctly rounded value for |x| ≤ 1e5 rad. Larger or non-finite
// arguments go to std::sin and std::cos.
#pragma once

#include <cmath>
#include <cstddef>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace km {

namespace internal {

// Coefficients of fdlibm's __kernel_sin (r + r³·(S1 + r²·(S2 + …))) and __kernel_cos
// (1 − r²/2 + r⁴·(C1 + r²·(C2 + …))), and π/2 in three parts of 33 bits (q · part is exact for
// |q| < 2²⁰): shared by the scalar, two-lane and four-lane kernels.
inline constexpr double kSinCoef[6] = {-1.66666666666666324348e-01, 8.33333333332248946124e-03,
                                       -1.98412698298579493134e-04, 2.75573137070700676789e-06,
                                       -2.50507602534068634195e-08, 1.58969099521155010221e-10};
inline constexpr double kCosCoef[6] = {4.16666666666666019037e-02, -1.38888888888741095749e-03,
                                       2.48015872894767294178e-05, -2.75573143513906633035e-07,
                                       2.08757232129817482790e-09, -1.13596475577881948265e-11};
inline constexpr double kPio2Parts[3] = {1.57079632673412561417e+00, 6.07710050630396597660e-11,
                                         2.02226624871116645580e-21};
inline constexpr double kTwoOverPi = 0.63661977236758134308;

// sin(r) and cos(r) for |r| ≤ π/4.
inline double KernelSin(double r) {
  const double z = r * r;
  const double p =
      kSinCoef[1] + z * (kSinCoef[2] + z * (kSinCoef[3] + z * (kSinCoef[4] + z * kSinCoef[5])));
  return r + z * r * (kSinCoef[0] + z * p);
}

inline double KernelCos(double r) {
  const double z = r * r;
  const double p =
      z * (kCosCoef[0] +
           z * (kCosCoef[1] +
                z * (kCosCoef[2] + z * (kCosCoef[3] + z * (kCosCoef[4] + z * kCosCoef[5])))));
  const double hz = 0.5 * z;
  const double w = 1.0 - hz;
  return w + (((1.0 - w) - hz) + z * p);
}

}  // namespace internal

inline void SinCos(double x, double* s, double* c) {
  if (!(std::abs(x) <= 1e5)) {
    *s = std::sin(x);
    *c = std::cos(x);
    return;
  }
  using internal::kPio2Parts;
  const double q = std::rint(x * internal::kTwoOverPi);
  const double r = ((x - q * kPio2Parts[0]) - q * kPio2Parts[1]) - q * kPio2Parts[2];
  const double sr = internal::KernelSin(r);
  const double cr = internal::KernelCos(r);
  // Quadrant k: (sin, cos) = (sr, cr), (cr, −sr), (−sr, −cr), (−cr, sr) for k = 0 … 3, chosen
  // without a branch (the quadrant of successive samples is not predictable).
  const auto k = static_cast<int>(static_cast<long long>(q) & 3);
  const double v[2] = {sr, cr};
  const double sign[2] = {1.0, -1.0};
  *s = v[k & 1] * sign[k >> 1];
  *c = v[(k & 1) ^ 1] * sign[((k + 1) >> 1) & 1];
}

#if defined(__SSE2__)
namespace internal {

// Two lanes of SinCos with the same operations in the same order (SSE2 arithmetic is the
// scalar arithmetic, lane by lane): the results are bit for bit those of SinCos. Both lanes
// within |x| ≤ 1e5.
inline void SinCos2(__m128d x, __m128d* s, __m128d* c) {
  const __m128d qd = _mm_mul_pd(x, _mm_set1_pd(kTwoOverPi));
  const __m128i qi = _mm_cvtpd_epi32(qd);  // round to nearest, ties to even: std::rint
  const __m128d q = _mm_cvtepi32_pd(qi);
  __m128d r = x;
  for (const double part : kPio2Parts) r = _mm_sub_pd(r, _mm_mul_pd(q, _mm_set1_pd(part)));
  const __m128d z = _mm_mul_pd(r, r);
  // Horner from the last coefficient: k + z·p at each step, a product then a sum.
  auto horner = [&z](const double* coef) {
    __m128d p = _mm_set1_pd(coef[5]);
    for (int k = 4; k >= 0; --k) p = _mm_add_pd(_mm_set1_pd(coef[k]), _mm_mul_pd(z, p));
    return p;
  };
  const __m128d sr = _mm_add_pd(r, _mm_mul_pd(_mm_mul_pd(z, r), horner(kSinCoef)));
  const __m128d pc = _mm_mul_pd(z, horner(kCosCoef));
  const __m128d hz = _mm_mul_pd(_mm_set1_pd(0.5), z);
  const __m128d w = _mm_sub_pd(_mm_set1_pd(1.0), hz);
  const __m128d cr =
      _mm_add_pd(w, _mm_add_pd(_mm_sub_pd(_mm_sub_pd(_mm_set1_pd(1.0), w), hz), _mm_mul_pd(z, pc)));
  // Quadrant k = q mod 4 (two's complement: also for negative q): (sin, cos) = (sr, cr),
  // (cr, −sr), (−sr, −cr), (−cr, sr); a factor −1 is a flip of the sign bit.
  const __m128i k = _mm_shuffle_epi32(_mm_and_si128(qi, _mm_set1_epi32(3)), 0x50);  // k0 k0 k1 k1
  const __m128i one = _mm_set1_epi32(1), two = _mm_set1_epi32(2);
  const __m128d odd = _mm_castsi128_pd(_mm_cmpeq_epi32(_mm_and_si128(k, one), one));
  const __m128d sin_neg = _mm_castsi128_pd(_mm_cmpeq_epi32(_mm_and_si128(k, two), two));
  const __m128i k1 = _mm_add_epi32(k, one);
  const __m128d cos_neg = _mm_castsi128_pd(_mm_cmpeq_epi32(_mm_and_si128(k1, two), two));
  const __m128d sign = _mm_set1_pd(-0.0);
  const __m128d sv = _mm_or_pd(_mm_and_pd(odd, cr), _mm_andnot_pd(odd, sr));
  const __m128d cv = _mm_or_pd(_mm_and_pd(odd, sr), _mm_andnot_pd(odd, cr));
  *s = _mm_xor_pd(sv, _mm_and_pd(sin_neg, sign));
  *c = _mm_xor_pd(cv, _mm_and_pd(cos_neg, sign));
}

}  // namespace internal
#endif

#if defined(__x86_64__) && defined(__GNUC__)
#define KM_SINCOS_AVX2 1
namespace internal {
// Whether the processor runs AVX2 (asked once).
bool SinCosHasAvx2();
// SinCosArray four lanes at a time with AVX2 (sincos.cpp): the same operations in the same
// order, so bit for bit SinCos.
void SinCosArrayAvx2(const double* x, double* s, double* c, std::size_t n);
}  // namespace internal
#endif

namespace internal {
// SinCosArray two lanes at a time with SSE2 (where available), bit for bit SinCos.
inline void SinCosArraySse2(const double* x, double* s, double* c, std::size_t n) {
  std::size_t i = 0;
#if defined(__SSE2__)
  // Four at a time: two independent chains of polynomial steps keep the pipeline busy.
  for (; i + 3 < n; i += 4) {
    if (!(std::abs(x[i]) <= 1e5 && std::abs(x[i + 1]) <= 1e5 && std::abs(x[i + 2]) <= 1e5 &&
          std::abs(x[i + 3]) <= 1e5)) {
      for (std::size_t j = i; j < i + 4; ++j) SinCos(x[j], s + j, c + j);
      continue;
    }
    __m128d s0, c0, s1, c1;
    internal::SinCos2(_mm_loadu_pd(x + i), &s0, &c0);
    internal::SinCos2(_mm_loadu_pd(x + i + 2), &s1, &c1);
    _mm_storeu_pd(s + i, s0);
    _mm_storeu_pd(c + i, c0);
    _mm_storeu_pd(s + i + 2, s1);
    _mm_storeu_pd(c + i + 2, c1);
  }
  for (; i + 1 < n; i += 2) {
    if (!(std::abs(x[i]) <= 1e5 && std::abs(x[i + 1]) <= 1e5)) {
      SinCos(x[i], s + i, c + i);
      SinCos(x[i + 1], s + i + 1, c + i + 1);
      continue;
    }
    __m128d sv, cv;
    internal::SinCos2(_mm_loadu_pd(x + i), &sv, &cv);
    _mm_storeu_pd(s + i, sv);
    _mm_storeu_pd(c + i, cv);
  }
#endif
  for (; i < n; ++i) SinCos(x[i], s + i, c + i);
}
}  // namespace internal

// SinCos of n arguments: s[i], c[i] bit for bit SinCos(x[i]), four at a time where the
// processor has AVX2, two at a time with SSE2.
inline void SinCosArray(const double* x, double* s, double* c, std::size_t n) {
#if KM_SINCOS_AVX2
  if (n >= 8 && internal::SinCosHasAvx2()) {
    internal::SinCosArrayAvx2(x, s, c, n);
    return;
  }
#endif
  internal::SinCosArraySse2(x, s, c, n);
}

}  // namespace km
