// servo_lag: radius reduction of a position loop with velocity feed-forward, [Fujita thesis]
// eq. 2.1:
//   Δr = −V²/(2R) · (1 − K_f²)/K_pp² = −c · V²/(2R),   c = (1 − K_f²)/K_pp²  [s²]
// (a pure delay only rotates the point along the path; the loop dynamics shrink the radius).
// Parameter c in ms²; e = Δr·n. The reported value is Δr in µm at the context's feed and
// radius (negative = reduction). It differs from radius_error only through its V²/R scaling,
// so the two are separated only by tests at different feeds.
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

struct ServoLag {
  static constexpr const char* kBaseName = "servo_lag";
  static constexpr int kAxis = -1;
  static constexpr int kNumParams = 1;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"lag_coefficient_ms2"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = false;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {}; }

  // µm of radius change per ms² of c.
  static double Gain(const EffectContext& c) {
    const double v = c.SpeedMmPerS();
    return -1e-3 * v * v / (2.0 * c.radius_mm);  // 1e-6 s²/ms² · 1e3 µm/mm
  }
  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    const T dr = Gain(c) * p[0];
    e[0] = dr * a.c;
    e[1] = dr * a.s;
  }
  static std::vector<double> Value(const EffectContext& c, const double* p) {
    return {Gain(c) * p[0]};
  }
  static Eigen::MatrixXd ValueJacobian(const EffectContext& c, const double*) {
    return Eigen::MatrixXd::Constant(1, 1, Gain(c));
  }
};

}  // namespace km::serial_effects
