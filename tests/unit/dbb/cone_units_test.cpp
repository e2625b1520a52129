// Units of the DBB figures and the centre of the circular hysteresis, against the independent
// simulator (dbb_truth.h: the bar length computed exactly in 3-D from the in-plane tool error).
//
// Cone test: R = 144 mm, bar L = 150 mm, the moving-ball plane 42 mm from the fixed ball
// (√(144² + 42²) = 150). ISO 230-4 defines G, F, H and G(b) on the tool path, so the report
// gives the in-plane values: the bar reads (R / L)·Δr for an in-plane radial deviation Δr and
// the report multiplies back by L / R. Expected values are written here from the in-plane error
// the simulator is given (closed forms, or a linearised least-squares fit written below), to
// 0.01 µm; the second-order terms neglected by the analysis are below 10⁻³ µm here.
//
// Hysteresis: the circular hysteresis about the common least-squares centre of both traces
// (the ISO 230-4 figure, iso230.h) and about each trace's own centre, both computed here from
// the in-plane deviations of the same samples.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/full_analysis.h"
#include "tests/unit/dbb/dbb_truth.h"
#include "usecases/dbb_json.h"

namespace km::dbb {
namespace {

using truth::Kind;

using truth::kDeg;
constexpr double kTol = 0.01;  // µm

truth::Setup Cone(Direction d, std::vector<truth::Effect> effects) {
  truth::Setup st;
  st.direction = d;
  st.radius_mm = 144.0;
  st.bar_mm = 150.0;
  st.z_offset_mm = 42.0;
  st.centre_mm = {100.0, -50.0, 300.0};
  st.fixed_ball_err_um = {2.0, 4.0};
  st.effects = std::move(effects);
  return st;
}

std::vector<double> Turn(Direction d) {
  return truth::Angles(d, 0.0, 360.0, 0.1, true);
}

// In-plane radial deviation of the tool about the fixed ball, first order:
// (e(θ) − fixed-ball error) · (cos θ, sin θ).
std::vector<double> InPlaneDeviation(const truth::Setup& st, const std::vector<double>& deg) {
  std::vector<double> d;
  for (double a : deg) {
    const double th = a * kDeg;
    double eu = -st.fixed_ball_err_um[0], ev = -st.fixed_ball_err_um[1];
    for (const auto& e : st.effects) {
      const auto x = truth::ErrorUm(e, st, th);
      eu += x[0];
      ev += x[1];
    }
    d.push_back(eu * std::cos(th) + ev * std::sin(th));
  }
  return d;
}

// Linearised least-squares circle of one or more traces: d ≈ cu cos θ + cv sin θ + ρ.
Eigen::Vector3d LinearFit(const std::vector<const std::vector<double>*>& deg,
                          const std::vector<const std::vector<double>*>& d) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (std::size_t t = 0; t < deg.size(); ++t) {
    for (std::size_t i = 0; i < deg[t]->size(); ++i) {
      const double th = (*deg[t])[i] * kDeg;
      const Eigen::Vector3d b(std::cos(th), std::sin(th), 1.0);
      m += b * b.transpose();
      v += b * (*d[t])[i];
    }
  }
  return m.ldlt().solve(v);
}

// d minus the centre terms of `fit` (ρ kept): the deviation about that centre.
std::vector<double> AboutCentre(const std::vector<double>& deg, const std::vector<double>& d,
                                const Eigen::Vector3d& fit) {
  std::vector<double> r(d.size());
  for (std::size_t i = 0; i < d.size(); ++i) {
    const double th = deg[i] * kDeg;
    r[i] = d[i] - fit[0] * std::cos(th) - fit[1] * std::sin(th);
  }
  return r;
}

TEST(ConeUnits, FiguresOfAConeTestAreInPlaneValues) {
  // In-plane error: radius +2 µm, scale mismatch 20 ppm (Δr = A cos 2θ, A = 20e-6·144 mm / 2
  // = 1.44 µm, so G = 2.88 µm), circle centre (5, −3) µm, fixed ball set up at (2, 4) µm.
  const double rho = 2.0, a = 20.0 * 144.0 * 1e-3 / 2.0;
  const truth::Setup st = Cone(Direction::kCcw, {{Kind::kRadius, 0, {rho}},
                                                 {Kind::kScaleMismatch, 0, {20.0}},
                                                 {Kind::kCentre, 0, {5.0, -3.0}}});
  const DbbTest t = truth::Simulate(st, Turn(st.direction));
  const DbbReport rep = AnalyzeDbbSet({t});
  const auto& r = rep.tests[0];
  EXPECT_EQ(r.circular.units, DeviationUnits::kToolPath);
  EXPECT_NEAR(r.circular.deviation_factor, 150.0 / 144.0, 1e-12);
  // Centre offset: tool circle centre relative to the fixed ball, in the plane.
  EXPECT_NEAR(r.circular.centre_offset_um[0], 5.0 - 2.0, kTol);
  EXPECT_NEAR(r.circular.centre_offset_um[1], -3.0 - 4.0, kTol);
  EXPECT_NEAR(r.circular.average_radial_error_um, rho, kTol);
  EXPECT_NEAR(r.circular.circularity_um, 2.0 * a, kTol);
  EXPECT_NEAR(r.iso230_4.circular_deviation_um, 2.0 * a, kTol);
  EXPECT_NEAR(r.iso230_4.radial_deviation_max_um, rho + a, kTol);
  EXPECT_NEAR(r.iso230_4.radial_deviation_min_um, rho - a, kTol);
  EXPECT_NEAR(r.min_zone_circularity_um, 2.0 * a, kTol);
  ASSERT_GE(r.harmonics.harmonics.size(), 2u);
  EXPECT_NEAR(r.harmonics.harmonics[1].amplitude_um, a, kTol);
  // The bar itself reads (R / L) of it: what the figures were before (bar units).
  const auto bar = AnalyzeCircularTest(t);
  EXPECT_EQ(bar.units, DeviationUnits::kBar);
  EXPECT_NEAR(bar.circularity_um, 2.0 * a * 144.0 / 150.0, kTol);
  EXPECT_NEAR(bar.centre_offset_um[0], 3.0 * 144.0 / 150.0, kTol);

  const nlohmann::json j = usecases::DbbTestToJson(r);
  EXPECT_EQ(j["deviation_units"], "tool path (in-plane)");
  EXPECT_NEAR(j["bar_to_tool_path_factor"].get<double>(), 150.0 / 144.0, 1e-12);
  EXPECT_EQ(j["iso230_4"]["deviation_units"], "tool path (in-plane)");
  EXPECT_NEAR(j["circularity_um"].get<double>(), 2.0 * a, kTol);
}

TEST(ConeUnits, AbsoluteModeOfAConeTestIsInPlane) {
  // The fixed ball measured where it stands: the centre offset is the machine's own in-plane
  // centre error, and the range about the fixed ball is that of the in-plane deviation.
  const double rho = -1.5;
  truth::Setup st = Cone(Direction::kCw, {{Kind::kRadius, 0, {rho}},
                                          {Kind::kScaleMismatch, 0, {-30.0}},
                                          {Kind::kCentre, 0, {6.0, 2.5}}});
  const std::vector<double> deg = Turn(st.direction);
  DbbTest t = truth::Simulate(st, deg);
  t.fixed_ball_mm = std::array<double, 3>{100.0 + 2e-3, -50.0 + 4e-3, 300.0};
  const auto r = AnalyzeDbbSet({t}).tests[0];
  EXPECT_NEAR(r.circular.centre_offset_um[0], 6.0, kTol);
  EXPECT_NEAR(r.circular.centre_offset_um[1], 2.5, kTol);
  ASSERT_TRUE(r.circular.machine_centre_error_um.has_value());
  EXPECT_NEAR((*r.circular.machine_centre_error_um)[0], 6.0, kTol);
  EXPECT_NEAR((*r.circular.machine_centre_error_um)[1], 2.5, kTol);
  st.fixed_ball_err_um = {0.0, 0.0};  // measured: the deviation is about the fixed ball
  const auto d = InPlaneDeviation(st, deg);
  const auto [mn, mx] = std::minmax_element(d.begin(), d.end());
  ASSERT_TRUE(r.circular.radial_error_range_um.has_value());
  EXPECT_NEAR(*r.circular.radial_error_range_um, *mx - *mn, kTol);
  EXPECT_NEAR(*r.circular.mean_radial_error_about_fixed_ball_um, rho, kTol);
  EXPECT_NEAR(r.iso230_4.radial_deviation_max_um, *mx, kTol);
  EXPECT_NEAR(r.iso230_4.radial_deviation_min_um, *mn, kTol);
}

TEST(ConeUnits, FlatTestIsUnchanged) {
  // L = R: factor 1, the tool-path figures equal the bar figures exactly.
  truth::Setup st = Cone(Direction::kCcw, {{Kind::kScaleMismatch, 0, {20.0}}});
  st.radius_mm = st.bar_mm = 150.0;
  st.z_offset_mm = 0.0;
  const DbbTest t = truth::Simulate(st, Turn(st.direction));
  const auto r = AnalyzeDbbSet({t}).tests[0];
  const auto bar = AnalyzeCircularTest(t);
  EXPECT_EQ(r.circular.deviation_factor, 1.0);
  EXPECT_EQ(r.circular.circularity_um, bar.circularity_um);
  EXPECT_EQ(r.circular.centre_offset_um, bar.centre_offset_um);
  EXPECT_EQ(r.circular.radial_error_um, bar.radial_error_um);
  EXPECT_NEAR(r.circular.circularity_um, 20.0 * 150.0 * 1e-3, kTol);
}

// Index of the sample of `deg` at the angle a (mod 360°, on the 0.1° grid of the tests).
std::size_t SampleAt(const std::vector<double>& deg, double a) {
  auto key = [](double x) { return ((std::llround(x * 10.0) % 3600) + 3600) % 3600; };
  for (std::size_t i = 0; i < deg.size(); ++i)
    if (key(deg[i]) == key(a)) return i;
  return deg.size();
}

// A cone pair with backlash (3 µm on the first axis), scale mismatch, and a circle centre that
// moved by (3, −0.5) µm between the ccw and the cw run: the common centre keeps that shift in
// H, each trace's own centre removes it. Both runs sample the same angles.
void CheckHysteresis(const std::vector<double>& deg_ccw, const std::vector<double>& deg_cw) {
  const std::vector<truth::Effect> common = {{Kind::kBacklash, 0, {3.0}},
                                             {Kind::kScaleMismatch, 0, {15.0}},
                                             {Kind::kCentre, 0, {5.0, -3.0}}};
  auto ccw_effects = common, cw_effects = common;
  ccw_effects.push_back({Kind::kCentre, 0, {1.5, 0.0}});
  cw_effects.push_back({Kind::kCentre, 0, {-1.5, 0.5}});
  const truth::Setup sccw = Cone(Direction::kCcw, ccw_effects);
  const truth::Setup scw = Cone(Direction::kCw, cw_effects);
  const DbbTest ccw = truth::Simulate(sccw, deg_ccw), cw = truth::Simulate(scw, deg_cw);

  // Independent figures from the in-plane deviations, compared at equal angles.
  const auto dccw = InPlaneDeviation(sccw, deg_ccw), dcw = InPlaneDeviation(scw, deg_cw);
  const Eigen::Vector3d both = LinearFit({&deg_ccw, &deg_cw}, {&dccw, &dcw});
  const auto own_ccw = AboutCentre(deg_ccw, dccw, LinearFit({&deg_ccw}, {&dccw}));
  const auto own_cw = AboutCentre(deg_cw, dcw, LinearFit({&deg_cw}, {&dcw}));
  const auto com_ccw = AboutCentre(deg_ccw, dccw, both), com_cw = AboutCentre(deg_cw, dcw, both);
  double h_common = 0.0, h_own = 0.0;
  for (std::size_t k = 0; k < deg_ccw.size(); ++k) {
    const std::size_t m = SampleAt(deg_cw, deg_ccw[k]);
    ASSERT_LT(m, deg_cw.size());
    h_common = std::max(h_common, std::abs(com_ccw[k] - com_cw[m]));
    h_own = std::max(h_own, std::abs(own_ccw[k] - own_cw[m]));
  }
  std::vector<double> all = com_ccw;
  all.insert(all.end(), com_cw.begin(), com_cw.end());
  const auto [mn, mx] = std::minmax_element(all.begin(), all.end());
  const double gb = *mx - *mn;
  ASSERT_GT(h_common - h_own, 1.0);  // the two conventions differ clearly in this case

  const DbbReport rep = AnalyzeDbbSet({ccw, cw});
  ASSERT_EQ(rep.pairs.size(), 1u);
  const auto& p = rep.pairs[0].iso230_4;
  EXPECT_EQ(p.units, DeviationUnits::kToolPath);
  EXPECT_NEAR(p.circular_hysteresis_um, h_common, kTol);
  EXPECT_NEAR(p.circular_hysteresis_own_centres_um, h_own, kTol);
  EXPECT_NEAR(p.bidirectional_circular_deviation_um, gb, kTol);
  EXPECT_NEAR(p.common_centre_um[0], both[0], kTol);
  EXPECT_NEAR(p.common_centre_um[1], both[1], kTol);

  const nlohmann::json j = usecases::DbbPairToJson(rep.pairs[0]);
  EXPECT_EQ(j["deviation_units"], "tool path (in-plane)");
  EXPECT_EQ(j["circular_hysteresis_centre"], "common least-squares centre");
  EXPECT_EQ(j["circular_hysteresis_own_centres_centre"], "own least-squares centre of each trace");
  EXPECT_NEAR(j["circular_hysteresis_um"].get<double>(), h_common, kTol);
  EXPECT_NEAR(j["circular_hysteresis_own_centres_um"].get<double>(), h_own, kTol);
}

TEST(ConeUnits, HysteresisAboutTheCommonAndTheOwnCentres) {
  CheckHysteresis(Turn(Direction::kCcw), Turn(Direction::kCw));
}

TEST(ConeUnits, HysteresisOverAPartialArc) {
  // A 220° arc (−20° … 200°) run both ways: every figure over the arc.
  CheckHysteresis(truth::Angles(Direction::kCcw, -20.0, 220.0, 0.1, false),
                  truth::Angles(Direction::kCw, 200.0, 220.0, 0.1, false));
}

}  // namespace
}  // namespace km::dbb
