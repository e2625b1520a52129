// servo_mismatch: the axes follow their commands with different lag times τ_u, τ_v:
//   e_u = −τ_u v_u,  e_v = −τ_v v_v,   v = s V (−sin θ, cos θ)
//   Δr = s V (τ_u − τ_v) sin θ cos θ = s (V/2) Δτ sin 2θ
// A common lag is tangential (invisible to first order), so only Δτ = τ_u − τ_v (ms) is a
// parameter; it is split ±Δτ/2. The 45° ellipse flips its tilt between cw and ccw (sign s) —
// this separates it from squareness. With V in mm/s and Δτ in ms, V·Δτ is in µm.
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

struct ServoMismatch {
  static constexpr const char* kBaseName = "servo_mismatch";
  static constexpr int kAxis = -1;
  static constexpr int kNumParams = 1;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"lag_difference_ms"};
  static constexpr const char* kUnit = "ms";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {}; }

  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    const double sv = c.direction * c.SpeedMmPerS();
    const T vu = -sv * a.s;
    const T vv = sv * a.c;
    e[0] = -0.5 * p[0] * vu;
    e[1] = 0.5 * p[0] * vv;
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 1);
  }
};

}  // namespace km::serial_effects
