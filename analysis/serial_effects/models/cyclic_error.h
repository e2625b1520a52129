// cyclic_error_<axis>: periodic positioning error of one axis along its own travel (ball-screw
// lead, encoder interpolation), position a = R cos θ (first axis) or R sin θ (second axis)
// measured from the circle centre:
//   e_a = c·cos(2π a / P) + d·sin(2π a / P),   amplitude A = √(c² + d²) µm, period P mm.
// Linear in (c, d) for a fixed period; P is a shape parameter (found by a period search).
#pragma once

#include "analysis/core/sincos.h"
#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

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
  // The radial projections of LinearBasis for n samples of one trace at once (cos θ, sin θ in
  // cs, sn; one SinCosArray for the lot): col0 = ∂Δr/∂c, col1 = ∂Δr/∂d, bit for bit what
  // ClosedFormBasis gives sample by sample. `arg` and `sn_arg`, `cs_arg` are work space of n.
  static void LinearBasisRows(const EffectContext& c, const double* cs, const double* sn, int n,
                              const double* shape, double* arg, double* sn_arg, double* cs_arg,
                              double* col0, double* col1) {
    const double* q = Axis == 0 ? cs : sn;
    for (int i = 0; i < n; ++i) arg[i] = (2.0 * std::numbers::pi) * (c.radius_mm * q[i]) / shape[0];
    SinCosArray(arg, sn_arg, cs_arg, static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      if constexpr (Axis == 0) {
        col0[i] = cs_arg[i] * cs[i] + 0.0 * sn[i];
        col1[i] = sn_arg[i] * cs[i] + 0.0 * sn[i];
      } else {
        col0[i] = 0.0 * cs[i] + cs_arg[i] * sn[i];
        col1[i] = 0.0 * cs[i] + sn_arg[i] * sn[i];
      }
    }
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

}  // namespace km::serial_effects
