// The one coverage rule of DBB tests (analysis/dbb/coverage.h): the largest gap between
// neighbouring samples, the closing gap included, is at most 10°; partial arcs of at least 180°
// (declared arc_deg or inferred). Expected figures come from an independent linearised
// least-squares circle written here (3 × 3 normal equations), not from the code under test.
#include "analysis/dbb/coverage.h"
#include "analysis/core/angles.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"
#include "ingest/dbb_parser.h"
#include "tests/unit/dbb_core/dbb_synth.h"

namespace km::dbb {
namespace {

// 0.1°/9° sampling: blocks of 11 samples 0.1° apart (1°), 9° between blocks, the last block
// ending at `end_deg` (the closing gap is 360 − end_deg).
std::vector<double> UnevenTurn(double end_deg) {
  std::vector<double> a;
  for (int b = 0; 10.0 * b + 1.0 <= end_deg + 1e-9; ++b)
    for (int j = 0; j <= 10; ++j) a.push_back(10.0 * b + 0.1 * j);
  return a;
}

// Synthetic test at the given angles: machine circle centre (cx, cy) µm, radius error rho µm
// and radial form f(θ), bar 150 mm, exact bar lengths (dbb_synth.h geometry, plane XY).
DbbTest Trace(const std::vector<double>& deg, double cx, double cy, double rho,
              double (*form)(double)) {
  DbbTest t;
  t.machine_id = "synthetic";
  t.test_id = "t";
  t.bar_length_mm = 150.0;
  t.radius_mm = 150.0;
  t.feed_mm_min = 1000.0;
  for (double d : deg) {
    const double th = d * kDeg;
    const double r = 150.0 + (rho + form(th)) / 1000.0;
    const double px = cx / 1000.0 + r * std::cos(th), py = cy / 1000.0 + r * std::sin(th);
    t.angle_deg.push_back(d);
    t.dr_um.push_back((std::hypot(px, py) - 150.0) * 1000.0);
  }
  return t;
}

// Independent linearised least-squares circle: dr ≈ cx cos θ + cy sin θ + ρ; returns
// (cx, cy, ρ, range of the residual).
std::array<double, 4> LinearCircle(const std::vector<double>& deg, const std::vector<double>& dr) {
  double m[3][3] = {}, v[3] = {};
  for (std::size_t i = 0; i < deg.size(); ++i) {
    const double b[3] = {std::cos(deg[i] * kDeg), std::sin(deg[i] * kDeg), 1.0};
    for (int r = 0; r < 3; ++r) {
      v[r] += b[r] * dr[i];
      for (int c = 0; c < 3; ++c) m[r][c] += b[r] * b[c];
    }
  }
  // Cramer's rule.
  auto det = [](double a[3][3]) {
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
           a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  };
  const double d = det(m);
  std::array<double, 4> x{};
  for (int k = 0; k < 3; ++k) {
    double a[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) a[r][c] = c == k ? v[r] : m[r][c];
    x[static_cast<std::size_t>(k)] = det(a) / d;
  }
  double mn = 1e300, mx = -1e300;
  for (std::size_t i = 0; i < deg.size(); ++i) {
    const double res =
        dr[i] - x[0] * std::cos(deg[i] * kDeg) - x[1] * std::sin(deg[i] * kDeg) - x[2];
    mn = std::min(mn, res);
    mx = std::max(mx, res);
  }
  x[3] = mx - mn;
  return x;
}

double Ellipse(double th) {
  return 3.0 * std::cos(2.0 * th);
}

double Flat(double) {
  return 0.0;
}

// The trace: 0.1°/9° sampling with a 9° closing gap was refused as "covering 351°".
TEST(Coverage, UnevenFullTurnWithA9DegreeClosingGapIsAccepted) {
  const auto a = UnevenTurn(351.0);
  ASSERT_NEAR(a.back(), 351.0, 1e-9);
  const Coverage c = CheckCoverage(a, Direction::kCcw, std::nullopt);
  ASSERT_TRUE(c.ok) << c.reason;
  EXPECT_TRUE(c.full_turn);
  EXPECT_DOUBLE_EQ(c.arc_deg, 360.0);
  EXPECT_NEAR(c.largest_gap_deg, 9.0, 1e-9);
  // Figures of the uneven turn: centre (8, −5) µm, radius +2 µm, a 3 µm ellipse; against the
  // independent least-squares circle of the same samples to 1e-3 µm, and the centre and
  // radius of a form-free machine exactly.
  const DbbTest t = Trace(a, 8.0, -5.0, 2.0, Ellipse);
  const auto r = AnalyzeCircularTest(t);
  EXPECT_TRUE(r.full_turn);
  EXPECT_EQ(r.sample_count, a.size());
  const auto lin = LinearCircle(t.angle_deg, t.dr_um);
  EXPECT_NEAR(r.centre_offset_um[0], lin[0], 1e-3);
  EXPECT_NEAR(r.centre_offset_um[1], lin[1], 1e-3);
  EXPECT_NEAR(r.average_radial_error_um, lin[2], 1e-3);
  EXPECT_NEAR(r.circularity_um, lin[3], 1e-3);
  const auto flat = AnalyzeCircularTest(Trace(a, 8.0, -5.0, 2.0, Flat));
  EXPECT_NEAR(flat.centre_offset_um[0], 8.0, 1e-3);
  EXPECT_NEAR(flat.centre_offset_um[1], -5.0, 1e-3);
  EXPECT_NEAR(flat.average_radial_error_um, 2.0, 1e-3);
  // Clockwise, the same samples in reverse order.
  DbbTest cw = t;
  std::reverse(cw.angle_deg.begin(), cw.angle_deg.end());
  std::reverse(cw.dr_um.begin(), cw.dr_um.end());
  cw.direction = Direction::kCw;
  EXPECT_NEAR(AnalyzeCircularTest(cw).circularity_um, lin[3], 1e-3);
}

// The same turn squeezed to end at 349°: an 11° closing gap.
std::vector<double> Turn349() {
  auto a = UnevenTurn(351.0);
  for (double& d : a) d *= 349.0 / 351.0;
  return a;
}

TEST(Coverage, TheLargestGapDecidesClosingGapIncluded) {
  // Declared full turn with an 11° closing gap: refused, and the message says which gap.
  const Coverage c = CheckCoverage(Turn349(), Direction::kCcw, 360.0);
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.reason.find("closing gap"), std::string::npos) << c.reason;
  EXPECT_NE(c.reason.find("11"), std::string::npos) << c.reason;
  // Undeclared, the same samples do not come back to their start: a partial arc of 349°.
  const Coverage as_arc = CheckCoverage(Turn349(), Direction::kCcw, std::nullopt);
  EXPECT_TRUE(as_arc.ok) << as_arc.reason;
  EXPECT_FALSE(as_arc.full_turn);
  EXPECT_NEAR(as_arc.arc_deg, 349.0, 1e-9);
  // Declared full turn, 9° closing gap: accepted; 10° steps exactly: accepted (36 samples).
  EXPECT_TRUE(CheckCoverage(UnevenTurn(351.0), Direction::kCcw, 360.0).ok);
  std::vector<double> ten;
  for (int i = 0; i < 36; ++i) ten.push_back(10.0 * i);
  EXPECT_TRUE(CheckCoverage(ten, Direction::kCcw, std::nullopt).ok);
  // An inner gap of 10.5°: refused, naming the samples around it.
  auto a = UnevenTurn(351.0);
  for (std::size_t i = 33; i < a.size(); ++i) a[i] += 1.5;  // 21° → 31.5°
  const Coverage g = CheckCoverage(a, Direction::kCcw, std::nullopt);
  EXPECT_FALSE(g.ok);
  EXPECT_EQ(g.reason_sample, 33u);
  EXPECT_NE(g.reason.find("10.5"), std::string::npos) << g.reason;
  // Fewer than 16 samples are no longer a rule of their own: a 180° arc of 19 samples at 10°.
  std::vector<double> arc;
  for (int i = 0; i <= 18; ++i) arc.push_back(10.0 * i);
  const Coverage s = CheckCoverage(arc, Direction::kCcw, std::nullopt);
  EXPECT_TRUE(s.ok) << s.reason;
  EXPECT_FALSE(s.full_turn);
  EXPECT_DOUBLE_EQ(s.arc_deg, 180.0);
}

TEST(Coverage, PartialArcsDeclaredOrInferred) {
  std::vector<double> a;  // −20° … 200°, 0.1° steps: a 220° arc
  for (int i = 0; i <= 2200; ++i) a.push_back(-20.0 + 0.1 * i);
  const Coverage inferred = CheckCoverage(a, Direction::kCcw, std::nullopt);
  ASSERT_TRUE(inferred.ok) << inferred.reason;
  EXPECT_FALSE(inferred.full_turn);
  EXPECT_NEAR(inferred.arc_deg, 220.0, 1e-9);
  EXPECT_TRUE(CheckCoverage(a, Direction::kCcw, 220.0).ok);
  // Declared 225° but 220° covered: the 5° missing at the end is a gap like any other.
  const Coverage short5 = CheckCoverage(a, Direction::kCcw, 225.0);
  EXPECT_TRUE(short5.ok) << short5.reason;
  EXPECT_FALSE(CheckCoverage(a, Direction::kCcw, 235.0).ok);
  // A declared full turn is refused for this arc; so is a declared arc below 180°.
  EXPECT_FALSE(CheckCoverage(a, Direction::kCcw, 360.0).ok);
  const Coverage tiny = CheckCoverage(a, Direction::kCcw, 120.0);
  EXPECT_FALSE(tiny.ok);
  EXPECT_EQ(tiny.field, "arc_deg");
}

TEST(Coverage, DeclaredArcWithOverrunIsEvaluatedOverTheCentredArc) {
  // Samples −30° … 210° (10° overrun each side), arc_deg 220: evaluated −20° … 200°.
  std::vector<double> deg;
  for (int i = 0; i <= 2400; ++i) deg.push_back(-30.0 + 0.1 * i);
  DbbTest t = Trace(deg, 5.0, 7.0, -1.0, Flat);
  for (std::size_t i = 0; i < 50; ++i) t.dr_um[i] += 40.0;  // overrun disturbance
  t.arc_deg = 220.0;
  const auto r = AnalyzeCircularTest(t);
  EXPECT_FALSE(r.full_turn);
  EXPECT_DOUBLE_EQ(r.arc_deg, 220.0);
  EXPECT_NEAR(r.turn_start_deg, -20.0, 1e-6);
  EXPECT_NEAR(r.turn_end_deg, 200.0, 1e-6);
  EXPECT_EQ(r.sample_count, 2201u);
  EXPECT_NEAR(r.centre_offset_um[0], 5.0, 1e-3);
  EXPECT_NEAR(r.centre_offset_um[1], 7.0, 1e-3);
  EXPECT_NEAR(r.average_radial_error_um, -1.0, 1e-3);
  EXPECT_LT(r.circularity_um, 1e-3);
}

std::string File(const std::string& extra, const std::vector<double>& deg) {
  std::string s =
      "# format: kinemetric-dbb/1\n# machine_id: m\n# test_id: t\n# direction: ccw\n"
      "# bar_length_mm: 150\n# centre_mm: 0, 0, 0\n# feed_mm_min: 1000\n" +
      extra + "angle_deg,dr_um\n";
  for (double d : deg) s += std::to_string(d) + ",0.1\n";
  return s;
}

TEST(Coverage, ParserAppliesTheSameRule) {
  // The 0.1°/9° turn is read.
  const auto t = ingest::ParseDbb(File("", UnevenTurn(351.0)), "uneven.dbb");
  EXPECT_EQ(t.angle_deg.size(), UnevenTurn(351.0).size());
  EXPECT_FALSE(t.arc_deg.has_value());
  // A declared full turn with an 11° closing gap is refused on the last row, field angle_deg.
  try {
    ingest::ParseDbb(File("# arc_deg: 360\n", Turn349()), "gap.dbb");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "angle_deg");
    EXPECT_EQ(e.line(), 9u + Turn349().size());
    EXPECT_NE(std::string(e.what()).find("closing gap"), std::string::npos) << e.what();
  }
  // arc_deg is read and checked on its own line.
  std::vector<double> arc;
  for (int i = 0; i <= 220; ++i) arc.push_back(-20.0 + i);
  const auto a = ingest::ParseDbb(File("# arc_deg: 220\n", arc), "arc.dbb");
  ASSERT_TRUE(a.arc_deg.has_value());
  EXPECT_DOUBLE_EQ(*a.arc_deg, 220.0);
  try {
    ingest::ParseDbb(File("# arc_deg: 90\n", arc), "arc90.dbb");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "arc_deg");
    EXPECT_EQ(e.line(), 8u);
  }
  // Without arc_deg the 220° arc is read too (the analysis infers the arc).
  EXPECT_NO_THROW(ingest::ParseDbb(File("", arc), "arc-inferred.dbb"));
}

}  // namespace
}  // namespace km::dbb
