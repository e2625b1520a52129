// reversal_spike_<axis>: at its reversal the axis sticks for a moment and only then follows
// the command (friction changes sign — [Fujita thesis] §"stick motion", quadrant glitch). Fixed
// shape: a one-sided exponential decay over the angle φ travelled since the reversal,
//   e_a = −h·sign(v_a)·exp(−φ / w)
// which is an outward radial spike of height h (µm) just after each reversal of that axis, on
// the side of the reversal the motion goes to (so cw and ccw spikes lie on opposite sides).
// Shape parameter w = decay angle in degrees (default 2°).
#pragma once

#include "analysis/effects/effect_model.h"

namespace km::effects {

template <int Axis>
struct ReversalSpike {
  static constexpr const char* kBaseName = "reversal_spike";
  static constexpr int kAxis = Axis;
  static constexpr int kNumParams = 2;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"height_um", "width_deg"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {2.0}; }

  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    using std::exp;
    const double sv = internal::SignOf(internal::AxisUnitVelocity(Axis, c.direction, a));
    const T phi =
        internal::AngleSinceReversal(a.theta, internal::AxisReversalAngle(Axis), c.direction);
    const T w = p[1] * (std::numbers::pi / 180.0);
    // exp(−40) is far below any measurable spike: skip the exponential there.
    e[Axis] = internal::ScalarPart(phi) > 40.0 * internal::ScalarPart(w)
                  ? T(0.0)
                  : T(-sv * p[0] * exp(-phi / w));
    e[1 - Axis] = T(0.0);
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 2);
  }
};

}  // namespace km::effects
