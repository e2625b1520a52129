// backlash_<axis>: lost motion b (µm) of one axis. The axis trails its command by b/2 against
// the direction of its motion, so its position steps by b where it reverses:
//   e_a = −(b/2)·sign(v_a)    (a = the axis; the other component is 0)
// On the first axis, Δr = (b/2)·s·sign(sin θ)·cos θ: an outward step b at θ = 0° and 180°
// for b > 0 (b < 0: over-compensated backlash, inward step).
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

template <int Axis>
struct Backlash {
  static constexpr const char* kBaseName = "backlash";
  static constexpr int kAxis = Axis;
  static constexpr int kNumParams = 1;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"step_um"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {}; }

  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    const double sv = internal::SignOf(internal::AxisUnitVelocity(Axis, c.direction, a));
    e[Axis] = -0.5 * sv * p[0];
    e[1 - Axis] = T(0.0);
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 1);
  }
};

}  // namespace km::serial_effects
