// reversal_spike_<axis>: at its reversal the axis sticks for a moment and only then follows
// the command (friction changes sign — [Fujita thesis] §"stick motion", quadrant glitch). A
// one-sided decay over the angle φ travelled since the reversal,
//   e_a = −h·sign(v_a)·exp(−(φ / w)^k / k)
// which is an outward radial spike of height h (µm) just after each reversal of that axis, on
// the side of the reversal the motion goes to (so cw and ccw spikes lie on opposite sides).
// Shape parameters: w = width in degrees (default 2°) and the exponent k (default 1):
//   k = 1  exponential decay exp(−φ/w), w = the decay constant;
//   k = 2  Gaussian-like decay exp(−φ²/(2w²)), w = the standard width.
// The diagnosis fits w (and chooses k = 1 or 2) per spike (analysis/dbb/diagnosis.h).
// Parameters: height_um, width_deg, exponent (exponent added after width_deg; a caller giving
// only the width gets k = 1, the former exponential model). k ≤ 0 is read as 1.
#pragma once

#include "analysis/serial_effects/effect_model.h"

namespace km::serial_effects {

template <int Axis>
struct ReversalSpike {
  static constexpr const char* kBaseName = "reversal_spike";
  static constexpr int kAxis = Axis;
  static constexpr int kNumParams = 3;
  static constexpr int kNumLinear = 1;
  static constexpr const char* kParamNames[] = {"height_um", "width_deg", "exponent"};
  static constexpr const char* kUnit = "um";
  static constexpr bool kInForm = true;
  static constexpr bool kLinearFit = true;
  static std::vector<double> DefaultShape() { return {2.0, 1.0}; }
  // Exponent actually used (k ≤ 0 reads as 1) and the argument φ / w beyond which the decay
  // is below exp(−40) and taken as 0.
  static double Exponent(double k) { return k > 0.0 ? k : 1.0; }
  static double CutOff(double k) {
    k = Exponent(k);
    return k == 1.0 ? 40.0 : (k == 2.0 ? std::sqrt(80.0) : std::pow(40.0 * k, 1.0 / k));
  }
  // The decay exp(−(φ/w)^k / k) at φ (rad) for the width w (rad); T may be a Jet.
  template <typename T>
  static T Decay(const T& phi, const T& w_rad, double k) {
    using std::exp;
    using std::pow;
    k = Exponent(k);
    if (internal::ScalarPart(phi) > CutOff(k) * internal::ScalarPart(w_rad)) return T(0.0);
    const T x = phi / w_rad;
    return exp(-(k == 1.0 ? x : (k == 2.0 ? T(0.5 * x * x) : T(pow(x, k) / k))));
  }

  // The spike is e_a = Side(c, a)·h·Decay(Phi(c, a), w, k): Side = −sign(v_a) after the reversal,
  // Phi = the angle travelled since the axis reversed (rad). A sample at the reversal itself
  // (within internal::kAtReversalRad) is the spike's peak, on the side the axis moves to.
  template <typename T>
  static internal::ReversalPhase<T> Phase(const EffectContext& c, const Angle<T>& a) {
    return internal::PhaseSinceReversal(a.theta, internal::AxisReversalAngle(Axis), c.direction);
  }
  template <typename T>
  static double Side(const EffectContext& c, const Angle<T>& a) {
    return Phase(c, a).side;
  }
  template <typename T>
  static T Phi(const EffectContext& c, const Angle<T>& a) {
    return Phase(c, a).phi;
  }

  template <typename T>
  static void PositionError(const EffectContext& c, const Angle<T>& a, const T* p, T* e) {
    const T w = p[1] * (std::numbers::pi / 180.0);
    e[1 - Axis] = T(0.0);
    const auto ph = Phase(c, a);
    e[Axis] = T(ph.side * p[0] * Decay(ph.phi, w, internal::ScalarPart(p[2])));
  }
  static std::vector<double> Value(const EffectContext&, const double* p) { return {p[0]}; }
  static Eigen::MatrixXd ValueJacobian(const EffectContext&, const double*) {
    return IdentityValueJacobian(1, 3);
  }
};

}  // namespace km::serial_effects
