#include "render/dbb_plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <utility>

#include <Eigen/Core>

#include "analysis/core/angles.h"
#include "analysis/core/errors.h"
#include "analysis/dbb/iso230.h"

namespace km::render {

using dbb::DbbReport;
using dbb::DbbTestReport;
using dbb::Direction;

namespace {

std::string Um(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f", v);
  return buf;
}

// Key figures of the plotted tests (and their pair) for the plot's lower left.
std::vector<std::string> KeyFigures(const DbbReport& report, const std::vector<std::size_t>& idx,
                                    const std::optional<std::size_t>& pair) {
  std::vector<std::string> notes;
  for (std::size_t i : idx) {
    const DbbTestReport& t = report.tests[i];
    notes.push_back(std::string(ToString(t.circular.direction)) + ": circularity " +
                    Um(t.circular.circularity_um) + " um, min. zone " +
                    Um(t.min_zone_circularity_um) + " um, centre (" +
                    Um(t.circular.centre_offset_um[0]) + ", " + Um(t.circular.centre_offset_um[1]) +
                    ") um");
  }
  if (pair) {
    const auto& f = report.pairs[*pair].iso230_4;
    notes.push_back("pair: G(b) " + Um(f.bidirectional_circular_deviation_um) + " um, H " +
                    Um(f.circular_hysteresis_um) + " um (ISO 230-4, tool path)");
  }
  return notes;
}

// The 1-2-5 step at least x (web/static/format.js niceStep).
double PageStep(double x) {
  if (!(x > 0) || !std::isfinite(x)) return 1.0;
  const double base = std::pow(10.0, std::floor(std::log10(x)));
  for (const double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * base >= x * (1 - 1e-9)) return m * base;
  }
  return 10.0 * base;
}

}  // namespace

PolarScale DbbPageScale(const DbbReport& report, std::size_t test_index) {
  if (test_index >= report.tests.size()) throw InvalidInput("", 0, "test", "no such test");
  std::vector<std::size_t> idx{test_index};
  if (const auto& pair = report.tests[test_index].pair) {
    idx = {report.pairs[*pair].ccw, report.pairs[*pair].cw};
  }
  double most = 0.0;
  for (std::size_t i : idx) {
    for (double e : report.tests[i].circular.radial_error_um) {
      if (std::isfinite(e)) most = std::max(most, std::abs(e));
    }
  }
  constexpr double kFillDivisions = 2.6;  // polar.js FILL_DIVS
  constexpr int kRings = 3;               // polar.js RINGS
  return {PageStep(std::max(most, 1e-3) / kFillDivisions), kRings};
}

DbbPolar DbbPolarPlot(const DbbReport& report, std::size_t test_index,
                      const PolarPlotOptions& options) {
  if (test_index >= report.tests.size()) throw InvalidInput("", 0, "test", "no such test");
  const DbbTestReport& t = report.tests[test_index];
  std::vector<std::size_t> idx{test_index};
  if (t.pair) {
    const auto& p = report.pairs[*t.pair];
    idx = {p.ccw, p.cw};
  }
  // Deviations of every trace about the chosen test's least-squares centre.
  const double cx = t.circular.centre_offset_um[0], cy = t.circular.centre_offset_um[1];
  const double r0 = t.circular.fitted_radius_mm * 1000.0;
  std::vector<PolarPlotTrace> traces;
  for (std::size_t i : idx) {
    const auto& c = report.tests[i].circular;
    const double rn = NominalRadiusUm(c);
    const auto dev = DeviationAboutNominalCentre(c);
    PolarPlotTrace pt;
    pt.label = ToString(c.direction);
    pt.bgr = c.direction == Direction::kCcw ? std::array<unsigned char, 3>{200, 60, 20}
                                            : std::array<unsigned char, 3>{30, 30, 210};
    for (std::size_t k = 0; k < dev.size(); ++k) {
      const double a = c.angle_deg[k] * kDeg;
      const Eigen::Vector2d q = (rn + dev[k]) * Eigen::Vector2d(std::cos(a), std::sin(a));
      pt.angle_rad.push_back(std::atan2(q.y() - cy, q.x() - cx));
      pt.dev_um.push_back(std::hypot(q.x() - cx, q.y() - cy) - r0);
    }
    traces.push_back(std::move(pt));
  }
  PolarPlotZone z;
  z.centre_um = {t.min_zone.centre.x() - cx, t.min_zone.centre.y() - cy};
  z.inner_um = t.min_zone.inner_radius - r0;
  z.outer_um = t.min_zone.outer_radius - r0;
  PolarPlotOptions o = options;
  if (o.notes.empty()) o.notes = KeyFigures(report, idx, t.pair);
  if (o.title.empty()) o.title = "DBB " + t.circular.test_id + " " + ToString(t.plane);
  const auto [a, b] = AxisLetters(t.plane);
  o.first_axis = std::string(1, static_cast<char>(a - 'a' + 'A'));
  o.second_axis = std::string(1, static_cast<char>(b - 'a' + 'A'));
  return {std::move(traces), z, std::move(o)};
}

std::vector<unsigned char> DbbPolarPlotPng(const DbbReport& report, std::size_t test_index,
                                           const PolarPlotOptions& options) {
  const DbbPolar p = DbbPolarPlot(report, test_index, options);
  return RenderPolarPlot(p.traces, p.zone, p.options);
}

}  // namespace km::render
