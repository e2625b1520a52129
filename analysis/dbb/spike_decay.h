// The unit reversal-spike decays of the width search (reversal_spike.h, exponents 1 and 2),
// vectorised:
//   out[k] = factor[k]·exp(−φ[k]/w)          (exponent 1)
//   out[k] = factor[k]·exp(−(φ[k]/w)²/2)     (exponent 2)
// Bit for bit what Eigen's array expression gives (its Cephes rational exp on pairs, std::exp on
// an odd last element), four at a time with AVX2 where the processor has it. Arguments must lie
// in the exp's normal range (the search evaluates decays down to e^−7 only).
#pragma once

#include <Eigen/Core>

namespace km::dbb::diag {

void SpikeDecays(const double* phi, const double* factor, Eigen::Index n, double w, bool gaussian,
                 double* out);

}  // namespace km::dbb::diag
