#include "analysis/dbb/spike_decay.h"

#include <cmath>

#include "analysis/core/cpu.h"
#include "analysis/core/exp4.h"

#if KM_EXP4_AVX2
#define KM_SPIKE_DECAY_AVX2 1
#endif

namespace km::dbb::diag {

namespace {

using ConstMap = Eigen::Map<const Eigen::ArrayXd>;

// Eigen's expression: the reference the vectorised path reproduces.
void DecaysEigen(const double* phi, const double* factor, Eigen::Index n, double w, bool gaussian,
                 double* out) {
  const auto x = ConstMap(phi, n) / w;
  Eigen::Map<Eigen::ArrayXd> v(out, n);
  if (gaussian)
    v = ConstMap(factor, n) * (-0.5 * x.square()).exp();
  else
    v = ConstMap(factor, n) * (-x).exp();
}

#if KM_SPIKE_DECAY_AVX2

__attribute__((target("avx2"))) void DecaysAvx2(const double* phi, const double* factor,
                                                Eigen::Index n, double w, bool gaussian,
                                                double* out) {
  const Eigen::Index pairs = n & ~Eigen::Index{1};  // Eigen's packets end here
  const __m256d wv = _mm256_set1_pd(w);
  Eigen::Index k = 0;
  for (; k + 4 <= pairs; k += 4) {
    const __m256d x = _mm256_div_pd(_mm256_loadu_pd(phi + k), wv);
    const __m256d arg = gaussian ? _mm256_mul_pd(_mm256_set1_pd(-0.5), _mm256_mul_pd(x, x))
                                 : _mm256_xor_pd(x, _mm256_set1_pd(-0.0));
    _mm256_storeu_pd(out + k, _mm256_mul_pd(_mm256_loadu_pd(factor + k), Exp4(arg)));
  }
  // The last pair (if any) as Eigen's packet, the odd element with std::exp as Eigen does.
  DecaysEigen(phi + k, factor + k, n - k, w, gaussian, out + k);
}

#endif

}  // namespace

void SpikeDecays(const double* phi, const double* factor, Eigen::Index n, double w, bool gaussian,
                 double* out) {
#if KM_SPIKE_DECAY_AVX2
  if (CpuHasAvx2()) {
    DecaysAvx2(phi, factor, n, w, gaussian, out);
    return;
  }
#endif
  DecaysEigen(phi, factor, n, w, gaussian, out);
}

}  // namespace km::dbb::diag
