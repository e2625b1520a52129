#include "analysis/dbb/circular_test.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Core>

#include "analysis/core/errors.h"
#include "analysis/core/extremes.h"
#include "analysis/core/sincos.h"
#include "analysis/dbb/coverage.h"
#include "analysis/geometry/circle_fit.h"

namespace km::dbb {

const char* ToString(Direction d) {
  return d == Direction::kCcw ? "ccw" : "cw";
}

const char* ToString(Plane p) {
  switch (p) {
    case Plane::kXY:
      return "XY";
    case Plane::kYZ:
      return "YZ";
    case Plane::kZX:
      return "ZX";
  }
  return "XY";
}

const char* ToString(Mode m) {
  return m == Mode::kAbsolute ? "absolute" : "centre_corrected";
}

const char* ToString(DeviationUnits u) {
  return u == DeviationUnits::kToolPath ? "tool path (in-plane)" : "bar";
}

double ToolPathFactor(const DbbTest& test) {
  return test.bar_length_mm / test.radius_mm;  // Δr = Δl · L / R (circular_test.h)
}

std::array<std::array<double, 3>, 3> PlaneAxes(Plane plane) {
  switch (plane) {
    case Plane::kYZ:
      return {{{0, 1, 0}, {0, 0, 1}, {1, 0, 0}}};
    case Plane::kZX:
      return {{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}}};
    case Plane::kXY:
    default:
      return {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  }
}

std::array<double, 3> CommandedBallPosition(const DbbTest& test, double angle_rad) {
  const auto ax = PlaneAxes(test.plane);
  const double c = std::cos(angle_rad), s = std::sin(angle_rad);
  std::array<double, 3> p{};
  for (int k = 0; k < 3; ++k) {
    p[k] = test.centre_mm[k] + test.radius_mm * (c * ax[0][k] + s * ax[1][k]) +
           test.z_offset_mm * ax[2][k];
  }
  return p;
}

Turn SelectOneTurn(const DbbTest& test) {
  const auto& a = test.angle_deg;
  const std::size_t n = a.size();
  if (n != test.dr_um.size()) {
    throw InvalidInput("", 0, "dr_um", "angle and deviation columns differ in length");
  }
  const Coverage cov = CheckCoverage(a, test.direction, test.arc_deg);
  if (!cov.ok) throw InvalidInput("", 0, cov.field, cov.reason);
  const double sign = test.direction == Direction::kCcw ? 1.0 : -1.0;
  // Progress along the direction of motion, in degrees (strictly increasing: checked above).
  std::vector<double> prog(n);
  for (std::size_t i = 0; i < n; ++i) prog[i] = sign * (a[i] - a[0]);
  const double span = prog.back();
  const double mean_step = span / static_cast<double>(n - 1);
  const double eps = 1e-9;
  double w0 = 0.0;
  double w1 = 0.0;
  bool closed_end = false;
  if (cov.full_turn) {
    // 360° window [w0, w0 + 360) centred in the covered span (half-open, so a turn from 0 to
    // 360 inclusive uses 0 … 360 − h and does not count the start twice). Each sample stands for
    // one step of arc, so the rows cover span + step degrees; the window start is snapped down
    // to a whole number of steps from the first sample.
    const double covered = span + mean_step;
    if (covered > 360.0) w0 = std::floor((covered - 360.0) / 2.0 / mean_step + 1e-6) * mean_step;
    w1 = w0 + 360.0;
  } else {
    // Partial arc [w0, w0 + arc], both ends included, centred in the span when the samples run
    // past the arc (lead-in / lead-out).
    if (span > cov.arc_deg) {
      const double want = (span - cov.arc_deg) / 2.0;
      // Start at the sample nearest to the centred start.
      std::size_t k = 0;
      while (k + 1 < n && prog[k + 1] <= want + eps) ++k;
      if (k + 1 < n && prog[k + 1] - want < want - prog[k]) ++k;
      w0 = prog[k];
      if (w0 + cov.arc_deg > span + eps) w0 = span - cov.arc_deg;
    }
    w1 = w0 + cov.arc_deg;
    closed_end = true;
  }
  Turn t;
  t.full_turn = cov.full_turn;
  t.arc_deg = cov.arc_deg;
  bool first = true;
  t.angle_rad.reserve(n);
  t.dr_um.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (prog[i] < w0 - eps) continue;
    if (closed_end ? prog[i] > w1 + eps : prog[i] >= w1 - eps) continue;
    if (first) {
      t.first_index = i;
      first = false;
    }
    t.angle_rad.push_back(a[i] * std::numbers::pi / 180.0);
    t.dr_um.push_back(test.dr_um[i]);
  }
  t.start_deg = a[0] + sign * w0;
  t.end_deg = a[0] + sign * w1;
  return t;
}

namespace {

// Bar deviation attributed to the machine, times `factor` (bar → reported units,
// circular_test.h). Absolute mode first subtracts the bar-length change a perfect machine would
// show with the measured fixed ball.
std::vector<double> MachineDeviation(const DbbTest& test, const Turn& turn, double factor) {
  std::vector<double> dev = turn.dr_um;
  if (test.fixed_ball_mm) {
    const auto& f = *test.fixed_ball_mm;
    for (std::size_t i = 0; i < dev.size(); ++i) {
      const auto p = CommandedBallPosition(test, turn.angle_rad[i]);
      const double d = std::sqrt((p[0] - f[0]) * (p[0] - f[0]) + (p[1] - f[1]) * (p[1] - f[1]) +
                                 (p[2] - f[2]) * (p[2] - f[2]));
      dev[i] -= (d - test.bar_length_mm) * 1000.0;
    }
  }
  for (double& d : dev) d *= factor;
  return dev;
}

}  // namespace

CircularTestResult AnalyzeCircularTest(const DbbTest& test, DeviationUnits units) {
  if (!(test.bar_length_mm > 0.0)) {
    throw InvalidInput("", 0, "bar_length_mm", "must be positive");
  }
  if (!(test.radius_mm > 0.0)) throw InvalidInput("", 0, "radius_mm", "must be positive");
  Turn turn = SelectOneTurn(test);
  const std::size_t n = turn.angle_rad.size();
  CircularTestResult r;
  r.test_id = test.test_id;
  r.direction = test.direction;
  r.mode = test.fixed_ball_mm ? Mode::kAbsolute : Mode::kCentreCorrected;
  r.units = units;
  r.deviation_factor = units == DeviationUnits::kToolPath ? ToolPathFactor(test) : 1.0;
  r.sample_count = n;
  r.turn_start_deg = turn.start_deg;
  r.turn_end_deg = turn.end_deg;
  r.full_turn = turn.full_turn;
  r.arc_deg = turn.arc_deg;

  const std::vector<double> dev = MachineDeviation(test, turn, r.deviation_factor);
  if (r.mode == Mode::kAbsolute) {
    const auto [mn, mx] = std::minmax_element(dev.begin(), dev.end());
    r.radial_error_range_um = *mx - *mn;
    double mean = 0.0;
    for (double v : dev) mean += v;
    r.mean_radial_error_about_fixed_ball_um = mean / static_cast<double>(n);
  }

  // Planar representation in µm about the commanded centre ([PM-600 report] §4.2.4).
  const double r_um = test.radius_mm * 1000.0;
  std::vector<Eigen::Vector2d> pts(n);
  r.cos_angle.resize(n);
  r.sin_angle.resize(n);
  // The sines and cosines two at a time (sincos.h; every later stage reads these).
  SinCosArray(turn.angle_rad.data(), r.sin_angle.data(), r.cos_angle.data(), n);
  for (std::size_t i = 0; i < n; ++i) {
    const double rho = r_um + dev[i];
    pts[i] = Eigen::Vector2d(rho * r.cos_angle[i], rho * r.sin_angle[i]);
  }
  const auto fit = geometry::FitCircleLeastSquares(pts);
  r.centre_offset_um = {fit.circle.centre.x(), fit.circle.centre.y()};
  r.average_radial_error_um = fit.circle.radius - r_um;
  r.fitted_radius_mm = fit.circle.radius / 1000.0;
  r.fit_rms_um = fit.rms_residual;
  r.radial_error_um = geometry::CircleResiduals(pts, fit.circle);
  const auto [mn, mx] = Extremes(r.radial_error_um.data(), r.radial_error_um.size());
  // eq. 4.7–4.8: the factors R/R_DBB and R_DBB/R cancel; Δ is the range about the fit.
  r.circularity_um = mx - mn;
  r.angle_deg.resize(n);
  for (std::size_t i = 0; i < n; ++i) r.angle_deg[i] = turn.angle_rad[i] * 180.0 / std::numbers::pi;
  if (r.mode == Mode::kAbsolute) {
    // A centre shift δ in the plane changes the bar length by (R / R_DBB)·δ·cos(θ − φ) on a
    // cone; scale back to the in-plane positioning error of the circle centre (in tool-path
    // units the centre offset already is that error).
    const double k = ToolPathFactor(test) / r.deviation_factor;
    r.machine_centre_error_um =
        std::array<double, 2>{r.centre_offset_um[0] * k, r.centre_offset_um[1] * k};
  }
  return r;
}

}  // namespace km::dbb
