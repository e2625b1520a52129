#include "analysis/dbb/spike_decay.h"

#include <cmath>

#include "analysis/core/cpu.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define KM_SPIKE_DECAY_AVX2 1
#endif

namespace km::dbb::diag {

namespace {

using ConstMap = Eigen::Map<const Eigen::ArrayXd>;

// Eigen's expression: the reference the vectorised path reproduces.
void DecaysEigen(const double* phi, const double* factor, Eigen::Index n, double w, bool gaussian,
                 double* out) {
  const auto x = ConstMap(phi, n) * (1.0 / w);
  Eigen::Map<Eigen::ArrayXd> v(out, n);
  if (gaussian)
    v = ConstMap(factor, n) * (-0.5 * x.square()).exp();
  else
    v = ConstMap(factor, n) * (-x).exp();
}

#if KM_SPIKE_DECAY_AVX2

// exp(x) for x ≤ 0 four lanes at a time with fused multiply-adds: x = n·ln 2 + r (two-part
// ln 2, |r| ≤ ln 2 / 2), e^r by its Taylor series to r¹² (the rest below 2·10⁻¹⁶ of e^r),
// times 2ⁿ built in the exponent bits. Within two ulps of std::exp; x below −700 (decays far
// below any sample's resolution) is taken as −700.
__attribute__((target("avx2,fma"))) __m256d ExpFma(__m256d x) {
  x = _mm256_max_pd(x, _mm256_set1_pd(-700.0));
  const __m256d n = _mm256_round_pd(_mm256_mul_pd(x, _mm256_set1_pd(1.4426950408889634)),
                                    _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  __m256d r = _mm256_fnmadd_pd(n, _mm256_set1_pd(6.93147180369123816490e-01), x);
  r = _mm256_fnmadd_pd(n, _mm256_set1_pd(1.90821492927058770002e-10), r);
  static constexpr double kInvFactorial[13] = {1.0,
                                               1.0,
                                               1.0 / 2,
                                               1.0 / 6,
                                               1.0 / 24,
                                               1.0 / 120,
                                               1.0 / 720,
                                               1.0 / 5040,
                                               1.0 / 40320,
                                               1.0 / 362880,
                                               1.0 / 3628800,
                                               1.0 / 39916800,
                                               1.0 / 479001600};
  __m256d p = _mm256_set1_pd(kInvFactorial[12]);
  for (int k = 11; k >= 0; --k) p = _mm256_fmadd_pd(p, r, _mm256_set1_pd(kInvFactorial[k]));
  // 2ⁿ for −1010 ≤ n ≤ 0: the biased exponent n + 1023 in the top bits.
  const __m128i ni = _mm256_cvtpd_epi32(n);
  const __m256i bits =
      _mm256_slli_epi64(_mm256_add_epi64(_mm256_cvtepi32_epi64(ni), _mm256_set1_epi64x(1023)), 52);
  return _mm256_mul_pd(p, _mm256_castsi256_pd(bits));
}

__attribute__((target("avx2,fma"))) void DecaysAvx2(const double* phi, const double* factor,
                                                    Eigen::Index n, double w, bool gaussian,
                                                    double* out) {
  const __m256d inv = _mm256_set1_pd(1.0 / w);
  Eigen::Index k = 0;
  for (; k + 4 <= n; k += 4) {
    const __m256d x = _mm256_mul_pd(_mm256_loadu_pd(phi + k), inv);
    const __m256d arg = gaussian ? _mm256_mul_pd(_mm256_set1_pd(-0.5), _mm256_mul_pd(x, x))
                                 : _mm256_xor_pd(x, _mm256_set1_pd(-0.0));
    _mm256_storeu_pd(out + k, _mm256_mul_pd(_mm256_loadu_pd(factor + k), ExpFma(arg)));
  }
  for (; k < n; ++k) {
    const double x = phi[k] * (1.0 / w);
    out[k] = factor[k] * std::exp(gaussian ? -0.5 * (x * x) : -x);
  }
}

#endif

}  // namespace

void SpikeDecays(const double* phi, const double* factor, Eigen::Index n, double w, bool gaussian,
                 double* out) {
#if KM_SPIKE_DECAY_AVX2
  if (CpuHasAvx2Fma()) {
    DecaysAvx2(phi, factor, n, w, gaussian, out);
    return;
  }
#endif
  DecaysEigen(phi, factor, n, w, gaussian, out);
}

}  // namespace km::dbb::diag
