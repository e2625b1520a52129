// StackedTraces::ComputeReversalPhases (signatures.h): every sample's angle since each axis
// reversed and the side after it, as serial_effects::internal::PhaseSinceReversal gives them,
// four samples at a time with AVX2 where the processor has it (the same operations: a quotient,
// its floor, a product and a difference, the two corrections; no fused products), the model's
// own function otherwise and for a block with an angle that is not finite.
#include <cmath>
#include <numbers>

#include "analysis/core/cpu.h"
#include "analysis/dbb/signatures.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define KM_REVERSAL_PHASES_AVX2 1
#endif

namespace km::dbb {

namespace {

// The model's phase of samples [from, to) for the axis whose reversals lie at theta0 + kπ.
void PhasesScalar(const StackedTraces& p, int axis, std::size_t from, std::size_t to, double* phi,
                  double* side) {
  for (std::size_t i = from; i < to; ++i) {
    const auto& s = p.samples[i];
    const auto& c = p.ctx[static_cast<std::size_t>(s.trace)];
    const auto ph = axis == 0 ? serial_effects::ReversalSpike<0>::Phase(c, s.a)
                              : serial_effects::ReversalSpike<1>::Phase(c, s.a);
    phi[i] = ph.phi;
    side[i] = ph.side;
  }
}

#if KM_REVERSAL_PHASES_AVX2

// Four samples from i of one trace (direction dir): true when done, false (nothing written) when
// an angle is not finite or its reversal count too large for the parity below.
__attribute__((target("avx2"))) bool Phases4(const double* theta, double theta0, double dir,
                                             double* phi, double* side) {
  constexpr double kPi = std::numbers::pi;
  const __m256d pi = _mm256_set1_pd(kPi), zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  const __m256d prog = _mm256_mul_pd(_mm256_set1_pd(dir),
                                     _mm256_sub_pd(_mm256_loadu_pd(theta), _mm256_set1_pd(theta0)));
  __m256d k = _mm256_floor_pd(_mm256_div_pd(prog, pi));
  // |k| < 2⁵⁰ (false for NaN): the parity below is exact.
  const __m256d small =
      _mm256_cmp_pd(_mm256_andnot_pd(_mm256_set1_pd(-0.0), k), _mm256_set1_pd(0x1p50), _CMP_LT_OQ);
  if (_mm256_movemask_pd(small) != 0xF) return false;
  __m256d f = _mm256_sub_pd(prog, _mm256_mul_pd(k, pi));
  // Within kAtReversalRad of the next reversal: at it.
  const __m256d at =
      _mm256_cmp_pd(f, _mm256_set1_pd(kPi - serial_effects::internal::kAtReversalRad), _CMP_GT_OQ);
  k = _mm256_add_pd(k, _mm256_and_pd(at, one));
  f = _mm256_blendv_pd(f, _mm256_sub_pd(f, pi), at);
  f = _mm256_andnot_pd(_mm256_cmp_pd(f, zero, _CMP_LT_OQ), f);  // below 0: 0
  // (−1)^k: k/2 − ⌊k/2⌋ is 0 or ½.
  const __m256d half = _mm256_mul_pd(k, _mm256_set1_pd(0.5));
  const __m256d odd = _mm256_sub_pd(half, _mm256_floor_pd(half));
  _mm256_storeu_pd(phi, f);
  _mm256_storeu_pd(side, _mm256_sub_pd(one, _mm256_mul_pd(_mm256_set1_pd(4.0), odd)));
  return true;
}

#endif

}  // namespace

void StackedTraces::ComputeReversalPhases() {
  for (int axis = 0; axis < 2; ++axis) {
    ReversalPhases& r = reversal_phase[static_cast<std::size_t>(axis)];
    r.phi.resize(static_cast<std::size_t>(n));
    r.side.resize(static_cast<std::size_t>(n));
    const double theta0 = serial_effects::internal::AxisReversalAngle(axis);
    for (int t = 0; t < traces; ++t) {
      std::size_t i = begin[static_cast<std::size_t>(t)];
      const std::size_t end = begin[static_cast<std::size_t>(t) + 1];
#if KM_REVERSAL_PHASES_AVX2
      if (CpuHasAvx2()) {
        const double dir = ctx[static_cast<std::size_t>(t)].direction;
        for (; i + 4 <= end; i += 4) {
          if (!Phases4(theta.data() + i, theta0, dir, r.phi.data() + i, r.side.data() + i))
            PhasesScalar(*this, axis, i, i + 4, r.phi.data(), r.side.data());
        }
      }
#endif
      PhasesScalar(*this, axis, i, end, r.phi.data(), r.side.data());
    }
  }
}

}  // namespace km::dbb
