// straightness_<axis>: the axis moves on a bowed guide: its path deviates sideways (along the
// other axis) by a parabola over the test diameter, S at the middle relative to the ends:
//   first axis:  e_v = S (1 − (u/R)²) = S sin²θ   →  Δr = S sin³θ = S (3 sin θ − sin 3θ)/4
//   second axis: e_u = S (1 − (v/R)²) = S cos²θ   →  Δr = S cos³θ = S (3 cos θ + cos 3θ)/4
// Same in cw and ccw (three lobes). The first-harmonic part is indistinguishable from a
// centre offset; the diagnosis attributes it to the centre and identifies S from the rest.
// Value S (µm, peak size; positive = middle of the travel displaced towards + other axis).
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

template <int Axis>
struct Straightness {
  static constexpr const char* kBaseName = "straightness";
  static constexpr int kAxis = Axis;
  static constexpr int kNumParams = 1;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"bow_um"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {}; }

  template <typename T>
  static void PositionError(const EffectContext&, const Angle<T>& a, const T* p, T* e) {
    const T q = Axis == 0 ? T(a.c) : T(a.s);
    e[1 - Axis] = p[0] * (1.0 - q * q);
    e[Axis] = T(0.0);
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 1);
  }
};

}  // namespace km::serial_effects
