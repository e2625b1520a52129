// The Monte Carlo model of a DBB pair's uncertainty (dbb_uncertainty.h DbbPairModel: the least
// squares circles linearised about the base fit, the warm-started minimum zone, H through the
// pair's geometry built once) against the full analysis of the same perturbed data
// (AnalyzeDbbSet: AnalyzeCircularTest, ComputeIso230, the full FitMinZoneCircle,
// ComputeIso230Pair): 20 draws of the size the propagation draws, every figure within 1e-6 µm.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/dbb_uncertainty.h"
#include "analysis/dbb/full_analysis.h"

namespace km::dbb {
namespace {

// A cw or ccw trace of 3 600 readings (R 150 mm, or a cone: bar 150 mm on R 144 mm), a 7.3 µm
// oval and a 2.1 µm third harmonic, 0.1 µm of scatter, the fixed ball `offset` µm off centre.
DbbTest DrawTrace(Direction dir, unsigned seed, double radius_mm, std::array<double, 2> offset) {
  DbbTest t;
  t.machine_id = "m";
  t.test_id = "xy";
  t.direction = dir;
  t.bar_length_mm = 150.0;
  t.radius_mm = radius_mm;
  t.z_offset_mm = std::sqrt(150.0 * 150.0 - radius_mm * radius_mm);
  t.feed_mm_min = 1000.0;
  std::mt19937_64 g(seed);
  std::normal_distribution<double> noise(0.0, 0.1);
  const double s = dir == Direction::kCcw ? 1.0 : -1.0;
  for (int i = 0; i < 3600; ++i) {
    const double a = s * 0.1 * i;
    const double th = a * std::numbers::pi / 180.0;
    t.angle_deg.push_back(a);
    t.dr_um.push_back(3.65 * std::cos(2.0 * th - 0.4) + 1.05 * std::cos(3.0 * th + 1.1) +
                      offset[0] * std::cos(th) + offset[1] * std::sin(th) + noise(g));
  }
  return t;
}

DbbReport AnalyzeDraw(const std::vector<DbbTest>& tests) {
  DbbAnalysisOptions o;
  o.threads = 1;
  o.diagnose = false;
  return AnalyzeDbbSet(tests, o);
}

// The ten figures of the full analysis, in the order of the model's outputs.
std::array<double, 10> DrawFigures(const DbbReport& r) {
  const auto& p = r.pairs.at(0);
  std::array<double, 10> y{};
  std::size_t j = 0;
  for (std::size_t t : {p.cw, p.ccw}) {
    const DbbTestReport& tr = r.tests[t];
    y[j++] = tr.circular.circularity_um;
    y[j++] = tr.iso230_4.circular_deviation_um;
    y[j++] = tr.min_zone_circularity_um;
    y[j++] = tr.circular.average_radial_error_um;
  }
  y[8] = p.iso230_4.circular_hysteresis_um;
  y[9] = p.iso230_4.bidirectional_circular_deviation_um;
  return y;
}

void CompareDraws(double radius_mm, std::array<double, 2> offset, double u_r, double u_bar) {
  std::vector<DbbTest> tests{DrawTrace(Direction::kCw, 1, radius_mm, offset),
                             DrawTrace(Direction::kCcw, 2, radius_mm, offset)};
  const DbbReport base = AnalyzeDraw(tests);
  const auto& p = base.pairs.at(0);
  DbbPairModel model(base.tests[p.cw], base.tests[p.ccw], u_r, u_r);
  const std::size_t first[2] = {SelectOneTurn(tests[p.cw]).first_index,
                                SelectOneTurn(tests[p.ccw]).first_index};
  const std::size_t n[2] = {model.cw_size(), model.ccw_size()};
  std::mt19937_64 g(38);
  std::normal_distribution<double> normal;
  double worst = 0.0;
  for (int draw = 0; draw < 20; ++draw) {
    std::vector<double> z(n[0] + n[1]);
    for (double& v : z) v = normal(g);
    const double c = u_bar * normal(g);
    std::array<double, 10> fast{};
    model.Evaluate(z, c, fast);
    // The same draw on the file's readings (bar units: the model moves the tool path by f·…).
    std::vector<DbbTest> moved = tests;
    std::size_t k = 0;
    for (int t = 0; t < 2; ++t) {
      DbbTest& m = moved[t == 0 ? p.cw : p.ccw];
      for (std::size_t i = 0; i < n[t]; ++i, ++k) m.dr_um[first[t] + i] += u_r * z[k] + c;
    }
    const std::array<double, 10> full = DrawFigures(AnalyzeDraw(moved));
    for (std::size_t j = 0; j < 10; ++j) {
      EXPECT_NEAR(fast[j], full[j], 1e-6) << "draw " << draw << " figure " << j;
      worst = std::max(worst, std::abs(fast[j] - full[j]));
    }
  }
  std::printf("largest difference of a figure: %.3g µm\n", worst);
}

TEST(DbbUncertaintyDraw, FlatPairMatchesTheFullAnalysis) {
  CompareDraws(150.0, {0.0, 0.0}, 0.37, 2.0);
}

TEST(DbbUncertaintyDraw, OffCentreConePairMatchesTheFullAnalysis) {
  // Bar 150 mm on R 144 mm (f = 1.04), the fixed ball 25 µm and −40 µm off the circle's centre,
  // larger reading noise.
  CompareDraws(144.0, {25.0, -40.0}, 1.0, 2.0);
}

}  // namespace
}  // namespace km::dbb
