// The unit reversal-spike decays of the width search and the spike signatures
// (reversal_spike.h, exponents 1 and 2), vectorised:
//   out[k] = factor[k]·exp(−φ[k]·(1/w))          (exponent 1)
//   out[k] = factor[k]·exp(−(φ[k]·(1/w))²/2)     (exponent 2)
// A product with the reciprocal width, not a quotient (the same argument to within an ulp), and
// with AVX2 and FMA a polynomial exponential four samples at a time (within two ulps of
// std::exp); otherwise Eigen's array expression. φ ≥ 0: the decays lie in (0, 1].
#pragma once

#include <Eigen/Core>

namespace km::dbb::diag {

void SpikeDecays(const double* phi, const double* factor, Eigen::Index n, double w, bool gaussian,
                 double* out);

}  // namespace km::dbb::diag
