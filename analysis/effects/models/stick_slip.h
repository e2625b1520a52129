// stick_slip: at low axis speed (near each axis's reversal, |v_a| < 0.2 V) friction makes the
// axis alternately stick and slip: a sawtooth of amplitude A (µm, peak) and angular period P
// (degrees of the circle, shape parameter) along that axis, against its direction of motion:
//   e_a = −A·sign(v_a)·(2·frac(φ / P) − 1)  while |v_a| < 0.2 V,   φ = angle since reversal.
// The phase of real stick-slip is random, so the diagnosis does not fit this shape by least
// squares (kLinearFit = false); it measures the excess high-frequency power near the
// reversals instead. The model is used by the simulation.
#pragma once

#include "analysis/effects/effect_model.h"

namespace km::effects {

struct StickSlip {
  static constexpr const char* kBaseName = "stick_slip";
  static constexpr int kAxis = -1;
  static constexpr int kNumParams = 2;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"amplitude_um", "period_deg"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = false;
  static constexpr double kZone = 0.2;  // |v_a| / V below which stick-slip occurs
  static std::vector<double> DefaultShape() { return {0.5}; }

  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    for (int ax = 0; ax < 2; ++ax) {
      const T va = internal::AxisUnitVelocity(ax, c.direction, a);
      e[ax] = T(0.0);
      if (std::abs(internal::ScalarPart(va)) >= kZone) continue;
      const T phi =
          internal::AngleSinceReversal(a.theta, internal::AxisReversalAngle(ax), c.direction) *
          (180.0 / std::numbers::pi);
      const double cyc = std::floor(internal::ScalarPart(phi / p[1]));
      const T frac = phi / p[1] - cyc;
      // Use the sign of the velocity after the reversal; φ may be close to π just before it.
      e[ax] = -internal::SignOf(va) * p[0] * (2.0 * frac - 1.0);
    }
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 2);
  }
};

}  // namespace km::effects
