// Small synthetic DBB traces for the core tests: a machine whose moving ball runs on a known
// circle (centre error, radius error, form error), measured by a bar against a fixed ball.
#pragma once

#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>

#include "analysis/dbb/dbb_types.h"

namespace km::test {

struct SynthOptions {
  double radius_mm = 150.0;
  double bar_mm = 150.0;
  double z_offset_mm = 0.0;
  double centre_err_um[2] = {0, 0};  // actual circle centre − commanded, plane axes
  double radius_err_um = 0.0;
  std::function<double(double)> form_um;    // radial form error at angle θ (rad)
  double fixed_ball_err_um[3] = {0, 0, 0};  // fixed ball − commanded centre
  double noise_um = 0.0;
  unsigned seed = 1;
  int samples = 3600;
  double start_deg = 0.0;
  double span_deg = 360.0;
  bool ccw = true;
};

// The true bar reading, computed exactly in 3-D (plane XY, commanded centre at the origin).
inline dbb::DbbTest MakeTrace(const SynthOptions& o) {
  dbb::DbbTest t;
  t.machine_id = "synthetic";
  t.test_id = "t";
  t.direction = o.ccw ? dbb::Direction::kCcw : dbb::Direction::kCw;
  t.bar_length_mm = o.bar_mm;
  t.radius_mm = o.radius_mm;
  t.z_offset_mm = o.z_offset_mm;
  t.feed_mm_min = 1000.0;
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> noise(0.0, o.noise_um);
  const double sign = o.ccw ? 1.0 : -1.0;
  for (int i = 0; i < o.samples; ++i) {
    const double deg = o.start_deg + sign * o.span_deg * i / o.samples;
    const double th = deg * std::numbers::pi / 180.0;
    const double r_mm =
        o.radius_mm + (o.radius_err_um + (o.form_um ? o.form_um(th) : 0.0)) / 1000.0;
    const double px = o.centre_err_um[0] / 1000.0 + r_mm * std::cos(th);
    const double py = o.centre_err_um[1] / 1000.0 + r_mm * std::sin(th);
    const double pz = o.z_offset_mm;
    const double fx = o.fixed_ball_err_um[0] / 1000.0, fy = o.fixed_ball_err_um[1] / 1000.0,
                 fz = o.fixed_ball_err_um[2] / 1000.0;
    const double bar =
        std::sqrt((px - fx) * (px - fx) + (py - fy) * (py - fy) + (pz - fz) * (pz - fz));
    t.angle_deg.push_back(deg);
    t.dr_um.push_back((bar - o.bar_mm) * 1000.0 + (o.noise_um > 0 ? noise(rng) : 0.0));
  }
  return t;
}

}  // namespace km::test
