// lateral_play_<axis>: the carriage of the axis has clearance in its guideways; the drive force
// takes it up to one side or the other depending on the direction of that axis's motion, so
// the carriage shifts SIDEWAYS (along the other axis) by ±p/2 with sign(v_a):
//   e_other = −(p/2)·sign(v_a)
// On the first axis: Δr = (p/2)·s·|sin θ| — a step that is tangential at the reversal (no
// radial step there), a direction-dependent bulge of the quadrants in between. Value p = peak
// size (µm).
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

template <int Axis>
struct LateralPlay {
  static constexpr const char* kBaseName = "lateral_play";
  static constexpr int kAxis = Axis;
  static constexpr int kNumParams = 1;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"play_um"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {}; }

  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    const double sv = internal::SignOf(internal::AxisUnitVelocity(Axis, c.direction, a));
    e[1 - Axis] = -0.5 * sv * p[0];
    e[Axis] = T(0.0);
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 1);
  }
};

}  // namespace km::serial_effects
