// radius_error: change ρ (µm) of the mean radius that does not depend on the feed (e.g. a
// common scale error of both axes, or a bar-calibration error):  e = ρ·n,  Δr = ρ.
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

struct RadiusError {
  static constexpr const char* kBaseName = "radius_error";
  static constexpr int kAxis = -1;
  static constexpr int kNumParams = 1;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"radius_change_um"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = false;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {}; }

  template <typename T>
  static void PositionError(const EffectContext&, const Angle<T>& a, const T* p, T* e) {
    e[0] = p[0] * a.c;
    e[1] = p[0] * a.s;
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 1);
  }
};

}  // namespace km::serial_effects
