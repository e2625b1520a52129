#include "tests/unit/servo/feed_truth.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <stdexcept>

namespace km::servo::feed_truth {
namespace {

constexpr double kPi = std::numbers::pi;

// A phase of the motion: standstill, speeding up, cruise or slowing down, in direction `dir`.
enum class Kind { kDwell, kUp, kCruise, kDown };

struct Phase {
  Kind kind = Kind::kDwell;
  double t0 = 0.0, duration = 0.0, x0 = 0.0, dir = 1.0, speed = 0.0, accel = 0.0;
  bool cosine = false;
};

struct State {
  double x = 0.0, v = 0.0, a = 0.0;
};

// Position, speed and acceleration `u` seconds into the phase.
State At(const Phase& p, double u) {
  const double V = p.speed, T = p.duration, s = p.dir;
  switch (p.kind) {
    case Kind::kDwell:
      return {p.x0, 0.0, 0.0};
    case Kind::kCruise:
      return {p.x0 + s * V * u, s * V, 0.0};
    case Kind::kUp:
      if (p.cosine) {
        const double w = kPi / T;
        return {p.x0 + s * 0.5 * V * (u - std::sin(w * u) / w), s * 0.5 * V * (1 - std::cos(w * u)),
                s * 0.5 * V * w * std::sin(w * u)};
      }
      return {p.x0 + s * 0.5 * p.accel * u * u, s * p.accel * u, s * p.accel};
    case Kind::kDown:
      if (p.cosine) {
        const double w = kPi / T;
        return {p.x0 + s * 0.5 * V * (u + std::sin(w * u) / w), s * 0.5 * V * (1 + std::cos(w * u)),
                -s * 0.5 * V * w * std::sin(w * u)};
      }
      return {p.x0 + s * (V * u - 0.5 * p.accel * u * u), s * (V - p.accel * u), -s * p.accel};
  }
  return {};
}

std::vector<Phase> Phases(const Motion& m) {
  std::vector<Phase> out;
  double t = 0.0, x = m.start_mm;
  const auto push = [&](Phase p) {
    p.t0 = t;
    p.x0 = x;
    out.push_back(p);
    t += p.duration;
    x = At(p, p.duration).x;
  };
  if (m.dwell_s > 0.0) push({Kind::kDwell, 0, m.dwell_s});
  for (const Move& mv : m.moves) {
    const double d = std::abs(mv.to_mm - x), dir = mv.to_mm > x ? 1.0 : -1.0;
    double v = mv.speed_mm_s;
    // Ramp time and distance at the peak acceleration.
    double tr = m.cosine_ramps ? kPi * v / (2 * m.accel_mm_s2) : v / m.accel_mm_s2;
    if (v * tr > d) throw std::invalid_argument("feed_truth: move too short for its speed");
    const double cruise = (d - v * tr) / v;
    push({Kind::kUp, 0, tr, 0, dir, v, m.accel_mm_s2, m.cosine_ramps});
    push({Kind::kCruise, 0, cruise, 0, dir, v});
    push({Kind::kDown, 0, tr, 0, dir, v, m.accel_mm_s2, m.cosine_ramps});
    if (m.dwell_s > 0.0) push({Kind::kDwell, 0, m.dwell_s});
  }
  return out;
}

// dz/dt of the bristles (z in µm, v in mm/s).
double Zdot(const Drive& d, double z, double v) {
  const double u = std::abs(v / d.vs_mm_s);
  const double shape =
      d.lorentzian ? 1.0 / (1.0 + u * u) : std::exp(-std::pow(u, d.stribeck_exponent));
  const double g = d.fc_N + (d.fs_N - d.fc_N) * shape;
  return 1e3 * v - d.sigma0_N_per_um * std::abs(1e3 * v) * z / g;
}

}  // namespace

Motion BackAndForth(double stroke_mm, const std::vector<double>& speeds_mm_s, int round_trips) {
  Motion m;
  for (double v : speeds_mm_s) {
    for (int k = 0; k < round_trips; ++k) {
      m.moves.push_back({stroke_mm, v});
      m.moves.push_back({0.0, v});
    }
  }
  return m;
}

Trace Simulate(const Drive& d, const Motion& m, unsigned seed) {
  const std::vector<Phase> phases = Phases(m);
  const double end = phases.back().t0 + phases.back().duration;
  std::size_t k = 0;
  const auto state = [&](double t) {
    while (k + 1 < phases.size() && t >= phases[k + 1].t0) ++k;
    while (k > 0 && t < phases[k].t0) --k;
    return At(phases[k], std::clamp(t - phases[k].t0, 0.0, phases[k].duration));
  };
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, d.noise_N);
  Trace tr;
  double z = 0.0;
  const auto n = static_cast<long>(end / m.sample_s);
  for (long i = 0; i <= n; ++i) {
    const double t = static_cast<double>(i) * m.sample_s;
    const State s = state(t);
    const double zd = Zdot(d, z, s.v);
    const double f = d.sigma0_N_per_um * z + d.sigma1_N_s_per_mm * 1e-3 * zd +
                     d.sigma2_N_s_per_mm * s.v + d.mass_kg * 1e-3 * s.a + d.offset_N +
                     d.slope_N_per_mm * s.x +
                     d.ripple_N * std::sin(2 * kPi * s.x / d.ripple_mm + d.ripple_phase_rad);
    tr.t_s.push_back(t);
    tr.x_mm.push_back(s.x);
    tr.v_mm_s.push_back(s.v);
    tr.a_mm_s2.push_back(s.a);
    tr.force_N.push_back(f + noise(rng));
    // RK4 on z along the analytic speed, in steps of at most 25 µs (stable for the bristles'
    // rate σ0 |v| / g up to 10⁵ /s).
    const int steps = std::max(m.substeps, static_cast<int>(std::ceil(m.sample_s / 25e-6)));
    const double h = m.sample_s / steps;
    for (int j = 0; j < steps; ++j) {
      const double tj = t + j * h;
      const double v1 = state(tj).v, v2 = state(tj + h / 2).v, v4 = state(tj + h).v;
      const double k1 = Zdot(d, z, v1), k2 = Zdot(d, z + h / 2 * k1, v2);
      const double k3 = Zdot(d, z + h / 2 * k2, v2), k4 = Zdot(d, z + h * k3, v4);
      z += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
  }
  return tr;
}

std::string ServoText(const Trace& t, const std::string& test_id) {
  std::string s = "# format: kinemetric-servo/1\n# machine_id: vmc-3axis\n# test_id: " + test_id +
                  "\n# motion: path\n# axis: X\n# force_unit: N\nt_s,pos_mm,force\n";
  char buf[96];
  for (std::size_t i = 0; i < t.t_s.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%.4f,%.7f,%.4f\n", t.t_s[i], t.x_mm[i], t.force_N[i]);
    s += buf;
  }
  return s;
}

}  // namespace km::servo::feed_truth
