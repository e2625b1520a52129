// stick_slip: at low axis speed (near each axis's reversal, |v_a| < 0.2 V) friction makes the
// axis alternately stick and slip: a sawtooth of amplitude A (µm, peak) and angular period P
// (degrees of the circle, shape parameter) along that axis, against its direction of motion:
//   e_a = −A·sign(v_a)·(2·frac(φ / P) − 1)  while |v_a| < 0.2 V,   φ = angle since reversal.
// At a jump between teeth (φ / P within 1e-9 of a whole number ≥ 1; the first tooth starts at
// the reversal itself, φ = 0) the value is the midpoint 0:
// which side a sample exactly on a jump falls is decided by rounding, not by the machine, so
// the model takes neither (a simulation and a fit that round differently then still agree).
// The diagnosis fits this signature like the others (period found by a periodogram over φ,
// amplitude by least squares, analysis/dbb/diagnosis.h); kLinearFit = false keeps it out of
// the fixed-shape candidate lists (its period must be searched first). The model is also used
// by the simulation.
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

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
      const double x = internal::ScalarPart(phi / p[1]);
      const double cyc = std::floor(x);
      if ((cyc >= 1.0 && x - cyc < 1e-9) || cyc + 1.0 - x < 1e-9) continue;  // midpoint 0
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

}  // namespace km::serial_effects
