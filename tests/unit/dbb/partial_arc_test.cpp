// Partial-arc tests as ballbar systems run them in vertical planes: a 220° arc (−20° … 200°) in
// the YZ plane, where a full circle would hit the table. Truth from the independent simulator
// (dbb_truth.h); expected circle figures from an independent linearised least-squares fit
// written here. The arc is stated in every result, the ISO 230-4 figures are over the arc, and
// the diagnosis fits what the arc identifies and lists the rest.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/diagnosis.h"
#include "analysis/dbb/full_analysis.h"
#include "analysis/dbb/iso230.h"
#include "tests/unit/dbb/dbb_test_util.h"
#include "tests/unit/dbb/dbb_truth.h"
#include "usecases/dbb_json.h"

namespace km::dbb {
namespace {

using test::Describe;
using test::Named;
using truth::Kind;

using truth::kDeg;

// The 220° arc of the test, in time order for the direction.
std::vector<double> Arc(Direction d, double step = 0.1) {
  return d == Direction::kCcw ? truth::Angles(d, -20.0, 220.0, step, false)
                              : truth::Angles(d, 200.0, 220.0, step, false);
}

truth::Setup Vertical(unsigned seed, std::vector<truth::Effect> effects, double noise = 0.1) {
  truth::Setup st;
  st.plane = Plane::kYZ;
  st.centre_mm = {0.0, 250.0, 120.0};
  st.seed = seed;
  st.noise_um = noise;
  st.fixed_ball_err_um = {4.0, -6.0};
  st.effects = std::move(effects);
  return st;
}

// Linearised least squares of dr ≈ cu cos θ + cv sin θ + ρ over the samples, with residuals.
struct Lin {
  double cu, cv, rho;
  std::vector<double> res;
};

Lin LinearCircle(const std::vector<double>& deg, const std::vector<double>& dr) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < deg.size(); ++i) {
    const Eigen::Vector3d b(std::cos(deg[i] * kDeg), std::sin(deg[i] * kDeg), 1.0);
    m += b * b.transpose();
    v += b * dr[i];
  }
  const Eigen::Vector3d x = m.ldlt().solve(v);
  Lin l{x[0], x[1], x[2], {}};
  for (std::size_t i = 0; i < deg.size(); ++i) {
    l.res.push_back(dr[i] - x[0] * std::cos(deg[i] * kDeg) - x[1] * std::sin(deg[i] * kDeg) - x[2]);
  }
  return l;
}

double Range(const std::vector<double>& v) {
  const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
  return *mx - *mn;
}

// The arc is inferred from the samples (no arc_deg) and evaluated over the arc: the centre, the
// radius and the circularity equal the independent fit over the same 2201 samples.
TEST(PartialArc, VerticalPlaneArcIsEvaluatedOverTheArc) {
  const truth::Setup st = Vertical(1, {{Kind::kCentre, 0, {6.0, -4.0}},
                                       {Kind::kScaleMismatch, 0, {20.0}},
                                       {Kind::kBacklash, 1, {3.0}}});
  const DbbTest t = truth::Simulate(st, Arc(Direction::kCcw));
  const auto r = AnalyzeCircularTest(t);
  EXPECT_FALSE(r.full_turn);
  EXPECT_NEAR(r.arc_deg, 220.0, 1e-9);
  EXPECT_NEAR(r.turn_start_deg, -20.0, 1e-9);
  EXPECT_NEAR(r.turn_end_deg, 200.0, 1e-9);
  EXPECT_EQ(r.sample_count, 2201u);
  const Lin lin = LinearCircle(t.angle_deg, t.dr_um);
  EXPECT_NEAR(r.centre_offset_um[0], lin.cu, 2e-3);
  EXPECT_NEAR(r.centre_offset_um[1], lin.cv, 2e-3);
  EXPECT_NEAR(r.average_radial_error_um, lin.rho, 2e-3);
  EXPECT_NEAR(r.circularity_um, Range(lin.res), 2e-3);
  // ISO 230-4 over the arc: G = range about the arc's least-squares circle, F from the
  // nominal radius; the figures say they are over a 220° arc.
  const auto f = ComputeIso230(r);
  EXPECT_FALSE(f.full_turn);
  EXPECT_NEAR(f.evaluated_arc_deg, 220.0, 1e-9);
  EXPECT_NEAR(f.circular_deviation_um, Range(lin.res), 2e-3);
  EXPECT_NEAR(f.radial_deviation_max_um,
              *std::max_element(lin.res.begin(), lin.res.end()) + lin.rho, 2e-3);
  EXPECT_NEAR(f.radial_deviation_min_um,
              *std::min_element(lin.res.begin(), lin.res.end()) + lin.rho, 2e-3);
}

// A cw + ccw pair on the arc: the diagnosis recovers squareness, scale mismatch and the Z
// backlash (whose reversal at 90° the arc covers) within 5 % and names nothing else than the
// set-up; the full analysis states the arc for the test, its ISO figures and the pair, and the
// hysteresis equals the independent computation over the common arc.
TEST(PartialArc, PairOnTheArcIsDiagnosedAndStatedAsAnArc) {
  for (unsigned seed : {2u, 3u, 4u}) {
    truth::Setup st = Vertical(seed, {{Kind::kSquareness, 0, {15.0}},
                                      {Kind::kScaleMismatch, 0, {20.0}},
                                      {Kind::kBacklash, 1, {3.0}}});
    std::vector<DbbTest> tests;
    st.direction = Direction::kCcw;
    tests.push_back(truth::Simulate(st, Arc(st.direction)));
    st.direction = Direction::kCw;
    st.seed += 500;
    tests.push_back(truth::Simulate(st, Arc(st.direction)));
    tests[0].arc_deg = 220.0;  // one declared, one inferred
    const auto rep = AnalyzeDbbSet(tests);
    ASSERT_EQ(rep.pairs.size(), 1u);
    const auto j = usecases::DbbReportToJson(rep);
    for (const auto& tj : j["tests"]) {
      EXPECT_EQ(tj["evaluated_over"], "partial_arc");
      EXPECT_NEAR(tj["evaluated_arc_deg"].get<double>(), 220.0, 1e-9);
      EXPECT_EQ(tj["iso230_4"]["evaluated_over"], "partial_arc");
      EXPECT_NEAR(tj["iso230_4"]["evaluated_arc_deg"].get<double>(), 220.0, 1e-9);
      EXPECT_LE(tj["min_zone_circularity_um"].get<double>(),
                tj["circularity_um"].get<double>() + 1e-9);
    }
    EXPECT_EQ(j["pairs"][0]["evaluated_over"], "partial_arc");
    EXPECT_NEAR(j["pairs"][0]["evaluated_arc_deg"].get<double>(), 220.0, 1e-6);
    // Hysteresis about the common least-squares circle of both arcs, compared at the common
    // sample angles (the truth samples both directions at the same angles).
    {
      std::vector<double> deg, dr;
      for (const auto& t : tests) {
        deg.insert(deg.end(), t.angle_deg.begin(), t.angle_deg.end());
        dr.insert(dr.end(), t.dr_um.begin(), t.dr_um.end());
      }
      const Lin lin = LinearCircle(deg, dr);
      const std::size_t n = tests[0].angle_deg.size();
      double h = 0.0;
      for (std::size_t i = 0; i < n; ++i)
        h = std::max(h, std::abs(lin.res[i] - lin.res[2 * n - 1 - i]));
      EXPECT_NEAR(rep.pairs[0].iso230_4.circular_hysteresis_um, h, 2e-3);
      EXPECT_NEAR(rep.pairs[0].iso230_4.bidirectional_circular_deviation_um, Range(lin.res), 2e-3);
    }
    std::vector<DiagnosisTrace> tr;
    for (const auto& t : tests) tr.push_back(MakeDiagnosisTrace(t, AnalyzeCircularTest(t)));
    const auto r = DiagnoseSerialDbb(tr, Plane::kYZ);
    const auto* sq = Named(r, "squareness");
    const auto* sc = Named(r, "scale_mismatch");
    const auto* bl = Named(r, "backlash_z");
    ASSERT_TRUE(sq && sc && bl) << Describe(r);
    EXPECT_NEAR(sq->value[0], 15.0, 0.75) << Describe(r);
    EXPECT_NEAR(sc->value[0], 20.0, 1.0) << Describe(r);
    EXPECT_NEAR(bl->value[0], 3.0, 0.15) << Describe(r);
    for (const auto& e : r.named) {
      EXPECT_TRUE(e.effect == "squareness" || e.effect == "scale_mismatch" ||
                  e.effect == "backlash_z" || e.effect == "centre_offset" ||
                  e.effect == "radius_error")
          << Describe(r);
    }
  }
}

// One direction on the arc: servo mismatch and squareness look alike (as on a full turn) and
// the arc adds its own confusions; what cannot be told apart is listed, not guessed, and the
// squareness is still recovered.
TEST(PartialArc, SingleArcListsWhatItCannotIdentify) {
  const truth::Setup st = Vertical(5, {{Kind::kSquareness, 0, {25.0}}});
  const DbbTest t = truth::Simulate(st, Arc(Direction::kCcw));
  const auto r = DiagnoseSerialDbb({MakeDiagnosisTrace(t, AnalyzeCircularTest(t))}, Plane::kYZ);
  const auto* sq = Named(r, "squareness");
  ASSERT_NE(sq, nullptr) << Describe(r);
  EXPECT_NEAR(sq->value[0], 25.0, 1.25) << Describe(r);
  bool servo = false;
  for (const auto& s : r.not_identifiable) servo |= s.rfind("servo_mismatch", 0) == 0;
  EXPECT_TRUE(servo) << Describe(r);
}

// The shortest arc accepted, 180° (100° … 280°), one direction: the scale mismatch is
// recovered; every value kept has a finite uncertainty and what the arc cannot separate is
// listed with its reason.
TEST(PartialArc, ShortestArcFitsWhatItIdentifies) {
  const truth::Setup st = Vertical(6, {{Kind::kScaleMismatch, 0, {30.0}}});
  const DbbTest t = truth::Simulate(st, truth::Angles(Direction::kCcw, 100.0, 180.0, 0.1, false));
  const auto c = AnalyzeCircularTest(t);
  EXPECT_FALSE(c.full_turn);
  EXPECT_NEAR(c.arc_deg, 180.0, 1e-9);
  const auto r = DiagnoseSerialDbb({MakeDiagnosisTrace(t, c)}, Plane::kYZ);
  for (const auto& e : r.candidates) {
    for (double u : e.uncertainty) EXPECT_TRUE(std::isfinite(u)) << e.effect;
  }
  // On this arc the lateral play of Z (a sideways shift of ±p/2 reversing at 90° and 270°,
  // the arc's ends) is all centre offset and radius; servo mismatch needs the other direction.
  bool play = false, servo = false;
  for (const auto& n : r.not_identifiable) {
    play |= n ==
            "lateral_play_z (indistinguishable from the centre offset and radius over the "
            "evaluated samples)";
    servo |= n.rfind("servo_mismatch", 0) == 0;
  }
  EXPECT_TRUE(play && servo) << Describe(r);
  const auto* sc = Named(r, "scale_mismatch");
  ASSERT_NE(sc, nullptr) << Describe(r);
  EXPECT_NEAR(sc->value[0], 30.0, 1.5) << Describe(r);
  for (const auto& e : r.named) {
    EXPECT_TRUE(e.effect == "scale_mismatch" || e.effect == "centre_offset" ||
                e.effect == "radius_error")
        << Describe(r);
  }
}

}  // namespace
}  // namespace km::dbb
