// Common vocabulary of the error-effect models of a serial (3-axis) machine seen by a DBB
// circular test in a plane with axes (first, second) = (u, v).
//
// Every effect is a forward model of the machine POSITION error e(θ) = (e_u, e_v) in µm at the
// commanded angle θ of the moving ball, for a given direction of motion s (+1 = ccw, −1 = cw,
// seen from +normal). The commanded path is P(θ) = C + R (cos θ, sin θ); its velocity is
//   v(θ) = s·V·(−sin θ, cos θ),  V = feed / 60 in mm/s.
// The DBB sees, to first order, the projection of e on the radial direction n = (cos θ, sin θ):
//   Δr(θ) = e_u cos θ + e_v sin θ                                               (radial signature)
// (exactly: |P + e − F| − |P − F|; the simulation uses the exact form).
//
// Each model is a struct with
//   kBaseName, kAxis (−1: no axis; 0: first axis; 1: second axis → name "<base>_<letter>"),
//   kNumParams, kNumLinear (the first kNumLinear parameters enter e linearly; the rest are shape
//   parameters held fixed in a linear fit, e.g. a period), kParamNames, kUnit (unit of the
//   reported value), kInForm (true when the signature is part of the form error and counts in
//   the circularity; false for set-up / size terms: centre offset, radius, servo-lag radius),
//   DefaultShape() (initial values of the shape parameters),
//   template <typename T> static void PositionError(const EffectContext&, const Angle<T>& a,
//   const T* params, T* e) — a = (θ, cos θ, sin θ); usable with ceres::Jet,
//   static std::vector<double> Value(const double* params) — the reported value, and
//   static Eigen::MatrixXd ValueJacobian(const double* params) — d value / d params (for the
//   standard uncertainty by propagation of the parameter covariance).
#pragma once

#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Core>

namespace km::serial_effects {

// Commanded angle θ with its cosine and sine (computed once per sample; T may be a Jet).
template <typename T>
struct Angle {
  T theta;
  T c;
  T s;
};
template <typename T>
inline Angle<T> MakeAngle(const T& theta) {
  using std::cos;
  using std::sin;
  return Angle<T>{theta, cos(theta), sin(theta)};
}

struct EffectContext {
  // Values reported by Value() for rate-dependent effects are for this context.
  double radius_mm = 150.0;     // commanded circle radius R
  double feed_mm_min = 1000.0;  // programmed feed
  int direction = +1;           // +1 ccw, −1 cw
  double SpeedMmPerS() const { return feed_mm_min / 60.0; }
};

namespace internal {

// Scalar part of a double or a ceres::Jet (member `a`), for branch decisions.
inline double ScalarPart(double x) {
  return x;
}
template <typename J>
inline double ScalarPart(const J& j) {
  return j.a;
}

// Sign usable for double and ceres::Jet (its derivative is zero away from 0).
template <typename T>
inline double SignOf(const T& x) {
  const double v = ScalarPart(x);
  return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
}

// Angle travelled since the last reversal of an axis whose reversals lie at θ = θ0 + kπ,
// measured along the direction of motion s (result in [0, π)); T may be a Jet.
template <typename T>
inline T AngleSinceReversal(const T& theta, double theta0, int s) {
  const T prog = static_cast<double>(s) * (theta - theta0);
  const double k = std::floor(ScalarPart(prog) / std::numbers::pi);
  return prog - k * std::numbers::pi;
}

// A sample this close to an axis reversal (rad) is AT the reversal: angles that went through
// degrees and radians, or were computed from times, land a rounding error on either side of it.
inline constexpr double kAtReversalRad = 1e-6;

// Where an angle lies relative to the reversals θ0 + kπ of an axis, for direction s: the angle
// φ travelled since the last reversal along the motion, in [0, π), and (−1)^k of that reversal,
// the side the axis moves to after it: −sign(v_a) = (−1)^k for every angle after the reversal
// and before the next one. An angle within kAtReversalRad of a reversal is at it (φ = 0, the
// side after it) rather than at φ ≈ π with the side before it, or with the side of a velocity
// that is zero but for rounding. T may be a Jet.
template <typename T>
struct ReversalPhase {
  T phi;
  double side;
};
template <typename T>
inline ReversalPhase<T> PhaseSinceReversal(const T& theta, double theta0, int s) {
  constexpr double kPi = std::numbers::pi;
  const T prog = static_cast<double>(s) * (theta - theta0);
  double k = std::floor(ScalarPart(prog) / kPi);
  T phi = prog - k * kPi;
  if (ScalarPart(phi) > kPi - kAtReversalRad) {
    k += 1.0;
    phi = phi - kPi;
  }
  if (ScalarPart(phi) < 0.0) phi = T(0.0);
  return {phi, (static_cast<long long>(k) & 1) == 0 ? 1.0 : -1.0};
}

// Whether θ (rad) is at a reversal of either axis of the plane (a multiple of 90°, within
// kAtReversalRad).
inline bool AtAxisReversal(double theta) {
  constexpr double kQuarter = std::numbers::pi / 2.0;
  const double q = std::abs(theta / kQuarter);
  // |q − round(q)|, the distance to the nearest integer: below 2⁵² adding and taking away 2⁵²
  // rounds to an integer (a tie to the even one, at the same distance 0.5), without a call.
  constexpr double kShift = 4503599627370496.0;  // 2⁵²
  const double nearest = q < kShift ? (q + kShift) - kShift : q;
  return std::abs(q - nearest) * kQuarter < kAtReversalRad;
}

// Unit velocity component of axis `axis` (0 = u, 1 = v) along the circle for direction s:
// v_u / V = −s sin θ, v_v / V = s cos θ.
template <typename T>
inline T AxisUnitVelocity(int axis, int s, const Angle<T>& a) {
  return axis == 0 ? T(-static_cast<double>(s) * a.s) : T(static_cast<double>(s) * a.c);
}

// Commanded angle at which axis `axis` reverses (plus multiples of π).
inline double AxisReversalAngle(int axis) {
  return axis == 0 ? 0.0 : std::numbers::pi / 2.0;
}

}  // namespace internal

// Value jacobian of a value equal to the first `n` parameters (identity block).
inline Eigen::MatrixXd IdentityValueJacobian(int n_values, int n_params) {
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(n_values, n_params);
  for (int i = 0; i < n_values; ++i) j(i, i) = 1.0;
  return j;
}

}  // namespace km::serial_effects
