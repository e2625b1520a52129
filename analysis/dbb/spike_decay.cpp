#include "analysis/dbb/spike_decay.h"

#include <cmath>

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
  const auto x = ConstMap(phi, n) / w;
  Eigen::Map<Eigen::ArrayXd> v(out, n);
  if (gaussian)
    v = ConstMap(factor, n) * (-0.5 * x.square()).exp();
  else
    v = ConstMap(factor, n) * (-x).exp();
}

#if KM_SPIKE_DECAY_AVX2

// Eigen 3.4 pexp_double (GenericPacketMathFunctions.h) on four lanes, operation for operation
// (no fused multiply-add: Eigen's SSE2 pmadd is a product then a sum). The scaling by 2^n is
// exact for the normal results the search asks for.
__attribute__((target("avx2"))) __m256d Exp4(__m256d x0) {
  __m256d x = _mm256_max_pd(_mm256_min_pd(x0, _mm256_set1_pd(709.784)), _mm256_set1_pd(-709.784));
  __m256d fx = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(1.4426950408889634073599), x),
                             _mm256_set1_pd(0.5));
  fx = _mm256_floor_pd(fx);
  x = _mm256_sub_pd(x, _mm256_mul_pd(fx, _mm256_set1_pd(0.693145751953125)));
  x = _mm256_sub_pd(x, _mm256_mul_pd(fx, _mm256_set1_pd(1.42860682030941723212e-6)));
  const __m256d x2 = _mm256_mul_pd(x, x);
  __m256d px = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(1.26177193074810590878e-4), x2),
                             _mm256_set1_pd(3.02994407707441961300e-2));
  px = _mm256_add_pd(_mm256_mul_pd(px, x2), _mm256_set1_pd(9.99999999999999999910e-1));
  px = _mm256_mul_pd(px, x);
  __m256d qx = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(3.00198505138664455042e-6), x2),
                             _mm256_set1_pd(2.52448340349684104192e-3));
  qx = _mm256_add_pd(_mm256_mul_pd(qx, x2), _mm256_set1_pd(2.27265548208155028766e-1));
  qx = _mm256_add_pd(_mm256_mul_pd(qx, x2), _mm256_set1_pd(2.00000000000000000009e0));
  x = _mm256_div_pd(px, _mm256_sub_pd(qx, px));
  x = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(2.0), x), _mm256_set1_pd(1.0));
  const __m256i e = _mm256_cvtepi32_epi64(_mm256_cvtpd_epi32(fx));
  const __m256i bits = _mm256_slli_epi64(_mm256_add_epi64(e, _mm256_set1_epi64x(1023)), 52);
  return _mm256_max_pd(_mm256_mul_pd(x, _mm256_castsi256_pd(bits)), x0);
}

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

bool HasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

#endif

}  // namespace

void SpikeDecays(const double* phi, const double* factor, Eigen::Index n, double w, bool gaussian,
                 double* out) {
#if KM_SPIKE_DECAY_AVX2
  if (HasAvx2()) {
    DecaysAvx2(phi, factor, n, w, gaussian, out);
    return;
  }
#endif
  DecaysEigen(phi, factor, n, w, gaussian, out);
}

}  // namespace km::dbb::diag
