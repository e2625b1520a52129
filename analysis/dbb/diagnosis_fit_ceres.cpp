// The diagnosis's one use of automatic differentiation (ceres::Jet): the derivative of a
// signature with respect to its shape parameter, for the uncertainty of fitted shapes.
#include <ceres/jet.h>

#include "analysis/dbb/diagnosis_fit.h"

namespace km::dbb::diag {

using Eigen::VectorXd;

// d s / d (first shape parameter) of a one-linear-parameter effect at unit value, set-up free,
// by automatic differentiation of the registry model.
VectorXd ShapeDerivative(const Problem& p, const Candidate& c) {
  using J = ceres::Jet<double, 1>;
  VectorXd d(p.n);
  J params[8];
  params[0] = J(1.0);
  for (std::size_t k = 0; k < c.shape.size() && k + 1 < 8; ++k) params[k + 1] = J(c.shape[k]);
  params[1].v[0] = 1.0;
  for (int i = 0; i < p.n; ++i) {
    const auto& s = p.samples[static_cast<std::size_t>(i)];
    const serial_effects::Angle<J> a{J(s.a.theta), J(s.a.c), J(s.a.s)};
    J e[2];
    serial_effects::PositionErrorT<J>(c.id, p.ctx[static_cast<std::size_t>(s.trace)], a, params, e);
    d[i] = e[0].v[0] * s.a.c + e[1].v[0] * s.a.s;
  }
  p.RemoveSetup(d);
  return d;
}

}  // namespace km::dbb::diag
