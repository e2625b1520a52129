// squareness: the second axis is tilted towards −u by the angle α, so the angle between +u and
// +v is 90° + α (value α in µm/m, positive when the angle exceeds 90°):
//   e_u = −α v = −α R sin θ,  e_v = 0,   Δr = −(α R/2) sin 2θ   (same in cw and ccw).
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

struct Squareness {
  static constexpr const char* kBaseName = "squareness";
  static constexpr int kAxis = -1;
  static constexpr int kNumParams = 1;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"squareness_um_per_m"};
  static constexpr const char* kUnit = "um/m";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {}; }

  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    // α [µm/m] · 1e-6 · R [mm] · 1e3 µm/mm = α · R · 1e-3 µm
    e[0] = -1e-3 * c.radius_mm * p[0] * a.s;
    e[1] = T(0.0);
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 1);
  }
};

}  // namespace km::serial_effects
