// centre_offset: the machine circle centre sits at (c_u, c_v) µm from the fixed ball:
//   e = (c_u, c_v),  Δr = c_u cos θ + c_v sin θ  (same in both directions; first harmonic).
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

struct CentreOffset {
  static constexpr const char* kBaseName = "centre_offset";
  static constexpr int kAxis = -1;
  static constexpr int kNumParams = 2;
  static constexpr int kNumLinear = 2;
  static constexpr const char* kParamNames[] = {"centre_u_um", "centre_v_um"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = false;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {}; }

  template <typename T>
  static void PositionError(const EffectContext&, const Angle<T>&, const T* p, T* e) {
    e[0] = p[0];
    e[1] = p[1];
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0], p[1]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(2, 2);
  }
};

}  // namespace km::serial_effects
