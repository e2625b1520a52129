// Truth simulator of DBB circular tests of a serial machine for the accuracy tests of the
// diagnosis, the coverage rule and partial arcs. It is INDEPENDENT of the code under test: it
// includes nothing of the effect registry, the signatures, the simulation or the analysis
// (dbb_types.h is only the data record the analysis reads). Each effect is written again from
// its physical definition (model header comments, contract names, units and signs):
//
//   commanded ball P(θ) = C + R (cos θ, sin θ) in the plane axes (u, v) + z_offset · normal;
//   direction s = +1 ccw, −1 cw; velocity v = s V (−sin θ, cos θ); an axis reverses where its
//   velocity component changes sign (u at 0°, 180°; v at 90°, 270°); φ_a = angle travelled
//   since the last reversal of axis a, along the motion, in [0°, 180°).
//
//   backlash_a        e_a = −(b/2) sign(v_a)
//   soft backlash     e_a = −(b/2) sign(v_a) (1 − 2 exp(−φ_a / t))      (not a product model)
//   reversal_spike_a  e_a = −h sign(v_a) exp(−φ_a / w)                 exponential decay, w deg
//                     e_a = −h sign(v_a) exp(−φ_a² / (2 w²))           Gaussian-like, width w deg
//   squareness        e_u = −α·1e-6·v_mm·1e3
//   scale_mismatch    e_u = +(Δk/2)·1e-6·u·1e3, e_v = −(Δk/2)·1e-6·v·1e3
//   cyclic_error_a    e_a = c cos(2π a/P) + d sin(2π a/P)
//   stick_slip        e_a = −A sign(v_a) (2 frac(φ_a / P) − 1) while |v_a| < 0.2 V
//   centre            machine circle centre offset (µm, plane axes)
//   radius            e = ρ (cos θ, sin θ): the tool circle ρ µm larger than commanded
//
// The bar length is computed exactly in 3-D, |P + e − F| with F = C + fixed-ball set-up error,
// and Gaussian noise is added to dr (std::mt19937, seeded). Angles are given explicitly so
// uneven sampling, lead-in arcs and partial arcs can be written.
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "analysis/dbb/dbb_types.h"

namespace km::dbb::truth {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDeg = kPi / 180.0;

enum class Kind {
  kBacklash,       // p = {b}
  kSoftBacklash,   // p = {b, take-up angle t deg}
  kSpikeExp,       // p = {h, w deg}
  kSpikeGauss,     // p = {h, w deg}
  kSquareness,     // p = {α µm/m}
  kScaleMismatch,  // p = {Δk ppm}
  kCyclic,         // p = {c, d, P mm}
  kStickSlip,      // p = {A, P deg}
  kCentre,         // p = {u, v} µm
  kRadius,         // p = {ρ} µm
};

struct Effect {
  Kind kind = Kind::kBacklash;
  int axis = 0;
  std::vector<double> p;
};

struct Setup {
  std::string test_id = "T1";
  Direction direction = Direction::kCcw;
  Plane plane = Plane::kXY;
  double radius_mm = 150.0;
  double bar_mm = 150.0;
  double z_offset_mm = 0.0;
  std::array<double, 3> centre_mm{0.0, 0.0, 0.0};
  double feed_mm_min = 1000.0;
  std::array<double, 2> fixed_ball_err_um{0.0, 0.0};
  double noise_um = 0.0;
  unsigned seed = 1;
  std::vector<Effect> effects;
};

inline double Sign(double x) {
  return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0);
}

inline std::array<std::array<double, 3>, 3> Axes(Plane p) {
  if (p == Plane::kYZ) return {{{0, 1, 0}, {0, 0, 1}, {1, 0, 0}}};
  if (p == Plane::kZX) return {{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}}};
  return {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
}

inline double UnitVelocity(int axis, int s, double th) {
  return axis == 0 ? -s * std::sin(th) : s * std::cos(th);
}

// Degrees travelled since axis `axis` last reversed.
inline double SinceReversalDeg(int axis, int s, double th) {
  const double th0 = axis == 0 ? 0.0 : kPi / 2.0;
  const double prog = s * (th - th0);
  return (prog - kPi * std::floor(prog / kPi)) / kDeg;
}

inline std::array<double, 2> ErrorUm(const Effect& e, const Setup& st, double th) {
  const int s = st.direction == Direction::kCcw ? 1 : -1;
  const int a = e.axis;
  const double u = st.radius_mm * std::cos(th), v = st.radius_mm * std::sin(th);
  std::array<double, 2> r{0.0, 0.0};
  const double sv = Sign(UnitVelocity(a, s, th));
  const double phi = SinceReversalDeg(a, s, th);
  switch (e.kind) {
    case Kind::kBacklash:
      r[a] = -0.5 * e.p[0] * sv;
      break;
    case Kind::kSoftBacklash:
      r[a] = -0.5 * e.p[0] * sv * (1.0 - 2.0 * std::exp(-phi / e.p[1]));
      break;
    case Kind::kSpikeExp:
      r[a] = -e.p[0] * sv * std::exp(-phi / e.p[1]);
      break;
    case Kind::kSpikeGauss:
      r[a] = -e.p[0] * sv * std::exp(-phi * phi / (2.0 * e.p[1] * e.p[1]));
      break;
    case Kind::kSquareness:
      r[0] = -e.p[0] * 1e-6 * v * 1e3;
      break;
    case Kind::kScaleMismatch:
      r[0] = 0.5 * e.p[0] * 1e-6 * u * 1e3;
      r[1] = -0.5 * e.p[0] * 1e-6 * v * 1e3;
      break;
    case Kind::kCyclic: {
      const double arg = 2.0 * kPi * (a == 0 ? u : v) / e.p[2];
      r[a] = e.p[0] * std::cos(arg) + e.p[1] * std::sin(arg);
      break;
    }
    case Kind::kStickSlip:
      for (int ax = 0; ax < 2; ++ax) {
        const double va = UnitVelocity(ax, s, th);
        if (std::abs(va) >= 0.2) continue;
        const double f = SinceReversalDeg(ax, s, th) / e.p[1];
        r[ax] += -e.p[0] * Sign(va) * (2.0 * (f - std::floor(f)) - 1.0);
      }
      break;
    case Kind::kCentre:
      r[0] = e.p[0];
      r[1] = e.p[1];
      break;
    case Kind::kRadius:
      r[0] = e.p[0] * std::cos(th);
      r[1] = e.p[0] * std::sin(th);
      break;
  }
  return r;
}

// A test sampled at the given commanded angles (degrees, in time order).
inline DbbTest Simulate(const Setup& st, const std::vector<double>& angles_deg) {
  DbbTest t;
  t.machine_id = "truth";
  t.test_id = st.test_id;
  t.direction = st.direction;
  t.plane = st.plane;
  t.bar_length_mm = st.bar_mm;
  t.radius_mm = st.radius_mm;
  t.centre_mm = st.centre_mm;
  t.z_offset_mm = st.z_offset_mm;
  t.feed_mm_min = st.feed_mm_min;
  const auto ax = Axes(st.plane);
  std::array<double, 3> f{};
  for (int k = 0; k < 3; ++k) {
    f[k] = st.centre_mm[k] +
           1e-3 * (st.fixed_ball_err_um[0] * ax[0][k] + st.fixed_ball_err_um[1] * ax[1][k]);
  }
  std::mt19937 rng(st.seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (double deg : angles_deg) {
    const double th = deg * kDeg;
    std::array<double, 2> e{0.0, 0.0};
    for (const auto& eff : st.effects) {
      const auto d = ErrorUm(eff, st, th);
      e[0] += d[0];
      e[1] += d[1];
    }
    const double pu = st.radius_mm * std::cos(th) + 1e-3 * e[0];
    const double pv = st.radius_mm * std::sin(th) + 1e-3 * e[1];
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double pk = st.centre_mm[k] + pu * ax[0][k] + pv * ax[1][k] + st.z_offset_mm * ax[2][k];
      d2 += (pk - f[k]) * (pk - f[k]);
    }
    t.angle_deg.push_back(deg);
    t.dr_um.push_back((std::sqrt(d2) - st.bar_mm) * 1000.0 + st.noise_um * noise(rng));
  }
  return t;
}

// Evenly spaced angles from `start` over `span` degrees along the direction; `closed` = false
// includes the end point (an arc), true leaves it out (a full turn: the end is the start).
inline std::vector<double> Angles(Direction d, double start, double span, double step,
                                  bool closed) {
  const double s = d == Direction::kCcw ? 1.0 : -1.0;
  const auto n = static_cast<long>(std::llround(span / step)) + (closed ? 0 : 1);
  std::vector<double> a;
  for (long i = 0; i < n; ++i) a.push_back(start + s * step * static_cast<double>(i));
  return a;
}

// A cw + ccw pair (ccw first) over a full turn at `step` degrees.
inline std::vector<DbbTest> Pair(Setup st, double step = 0.1) {
  std::vector<DbbTest> v;
  st.direction = Direction::kCcw;
  v.push_back(Simulate(st, Angles(st.direction, 0.0, 360.0, step, true)));
  st.direction = Direction::kCw;
  st.seed += 1000;
  v.push_back(Simulate(st, Angles(st.direction, 0.0, 360.0, step, true)));
  return v;
}

}  // namespace km::dbb::truth
