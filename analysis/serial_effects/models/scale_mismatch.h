// scale_mismatch: the axes have scale errors k_u, k_v; their mean is a radius change
// (radius_error), their difference Δk = k_u − k_v (ppm) is split ±Δk/2:
//   e_u = +(Δk/2)·1e-6·u,  e_v = −(Δk/2)·1e-6·v,   Δr = (Δk/2)·1e-6·R cos 2θ  (same in cw, ccw).
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

struct ScaleMismatch {
  static constexpr const char* kBaseName = "scale_mismatch";
  static constexpr int kAxis = -1;
  static constexpr int kNumParams = 1;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"scale_difference_ppm"};
  static constexpr const char* kUnit = "ppm";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {}; }

  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    const T k = 0.5e-3 * c.radius_mm * p[0];  // ppm · 1e-6 · R mm · 1e3 µm/mm
    e[0] = k * a.c;
    e[1] = -k * a.s;
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 1);
  }
};

}  // namespace km::serial_effects
