// Ceres cost functor of one interferometer reading ([Tracker paper] eq. 1 with an explicit dead
// path):
//
//   r = scale · (|u − U| − L − d)
//
// u: target position (3), U: tracker position (3), L: dead path of the reading's segment (1),
// d: the measured displacement. All lengths in mm; `scale` = 1000 gives residuals in µm.
#pragma once

#include <cmath>

#include <ceres/autodiff_cost_function.h>
#include <ceres/ceres.h>
#include <ceres/sized_cost_function.h>

namespace km::tracker {

struct DistanceReadingCost {
  DistanceReadingCost(double d_mm, double scale) : d_mm_(d_mm), scale_(scale) {}

  template <typename T>
  bool operator()(const T* const point, const T* const tracker, const T* const offset,
                  T* residual) const {
    const T dx = point[0] - tracker[0];
    const T dy = point[1] - tracker[1];
    const T dz = point[2] - tracker[2];
    using std::sqrt;
    residual[0] = T(scale_) * (sqrt(dx * dx + dy * dy + dz * dz) - offset[0] - T(d_mm_));
    return true;
  }

  static ceres::CostFunction* Create(double d_mm, double scale = 1e3) {
    return new ceres::AutoDiffCostFunction<DistanceReadingCost, 1, 3, 3, 1>(
        new DistanceReadingCost(d_mm, scale));
  }

 private:
  double d_mm_;
  double scale_;
};

// The same residual with its hand-written Jacobian (∂r/∂u = s·n, ∂r/∂U = −s·n, ∂r/∂L = −s,
// n = (u − U)/|u − U|); checked against DistanceReadingCost in the tests. Used by the solver.
class DistanceReadingAnalyticCost final : public ceres::SizedCostFunction<1, 3, 3, 1> {
 public:
  DistanceReadingAnalyticCost(double d_mm, double scale) : d_mm_(d_mm), scale_(scale) {}

  bool Evaluate(double const* const* p, double* residual, double** jac) const override {
    const double dx = p[0][0] - p[1][0];
    const double dy = p[0][1] - p[1][1];
    const double dz = p[0][2] - p[1][2];
    const double rho = std::sqrt(dx * dx + dy * dy + dz * dz);
    residual[0] = scale_ * (rho - p[2][0] - d_mm_);
    if (jac) {
      if (!(rho > 0)) return false;
      const double k = scale_ / rho;
      if (jac[0]) {
        jac[0][0] = k * dx;
        jac[0][1] = k * dy;
        jac[0][2] = k * dz;
      }
      if (jac[1]) {
        jac[1][0] = -k * dx;
        jac[1][1] = -k * dy;
        jac[1][2] = -k * dz;
      }
      if (jac[2]) jac[2][0] = -scale_;
    }
    return true;
  }

  static ceres::CostFunction* Create(double d_mm, double scale = 1e3) {
    return new DistanceReadingAnalyticCost(d_mm, scale);
  }

 private:
  double d_mm_;
  double scale_;
};

}  // namespace km::tracker
