// cyclic_error_<axis>: periodic positioning error of one axis along its own travel (ball-screw
// lead, encoder interpolation), position a = R cos θ (first axis) or R sin θ (second axis)
// measured from the circle centre:
//   e_a = c·cos(2π a / P) + d·sin(2π a / P),   amplitude A = √(c² + d²) µm, period P mm.
// Linear in (c, d) for a fixed period; P is a shape parameter (found by a period search).
#pragma once

#include "analysis/core/sincos.h"
#include "analysis/effects/effect_model.h"

namespace km::effects {

template <int Axis>
struct CyclicError {
  static constexpr const char* kBaseName = "cyclic_error";
  static constexpr int kAxis = Axis;
  static constexpr int kNumParams = 3;
  static constexpr int kNumLinear = 2;
  static constexpr const char* kParamNames[] = {"cos_um", "sin_um", "period_mm"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {10.0}; }

  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    using std::cos;
    using std::sin;
    const T pos = Axis == 0 ? T(c.radius_mm * a.c) : T(c.radius_mm * a.s);
    const T arg = (2.0 * std::numbers::pi) * pos / p[2];
    e[Axis] = p[0] * cos(arg) + p[1] * sin(arg);
    e[1 - Axis] = T(0.0);
  }
  // ∂e/∂c and ∂e/∂d at the period shape[0], in closed form (one sincos for both columns).
  static void LinearBasis(const EffectContext& c, const Angle<double>& a, const double* shape,
                          double (*e)[2]) {
    const double pos = c.radius_mm * (Axis == 0 ? a.c : a.s);
    const double arg = (2.0 * std::numbers::pi) * pos / shape[0];
    SinCos(arg, &e[1][Axis], &e[0][Axis]);
    e[0][1 - Axis] = 0.0;
    e[1][1 - Axis] = 0.0;
  }
  static std::vector<double> Value(const EffectContext&, const double* p) {
    return {std::hypot(p[0], p[1])};
  }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double* p) {
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(1, 3);
    const double a = std::hypot(p[0], p[1]);
    if (a > 0.0) {
      j(0, 0) = p[0] / a;
      j(0, 1) = p[1] / a;
    }
    return j;
  }
};

}  // namespace km::effects
