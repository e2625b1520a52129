#include "analysis/dbb/circular_test.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"
#include "tests/unit/dbb_core/dbb_synth.h"

namespace km::dbb {
namespace {

using km::test::MakeTrace;
using km::test::SynthOptions;

TEST(CircularTest, CentreCorrectedFiguresOfAKnownTrace) {
  // Centre error (8, −5) µm, radius error +2 µm, elliptic form error of amplitude 3 µm.
  SynthOptions o;
  o.centre_err_um[0] = 8.0;
  o.centre_err_um[1] = -5.0;
  o.radius_err_um = 2.0;
  o.form_um = [](double th) { return 3.0 * std::cos(2 * th); };
  for (bool ccw : {true, false}) {
    o.ccw = ccw;
    const auto r = AnalyzeCircularTest(MakeTrace(o));
    EXPECT_EQ(r.mode, Mode::kCentreCorrected);
    EXPECT_EQ(r.sample_count, 3600u);
    EXPECT_NEAR(r.centre_offset_um[0], 8.0, 1e-3);
    EXPECT_NEAR(r.centre_offset_um[1], -5.0, 1e-3);
    EXPECT_NEAR(r.average_radial_error_um, 2.0, 1e-3);
    // Range of 3·cos 2θ about the centre: 6 µm.
    EXPECT_NEAR(r.circularity_um, 6.0, 1e-3);
    EXPECT_FALSE(r.radial_error_range_um.has_value());
  }
}

TEST(CircularTest, AbsoluteModeReportsTheMachineCentreError) {
  // The fixed ball sits 20 µm / −10 µm off the commanded centre (measured by a CMM); the
  // machine's circle centre is off by (3, 4) µm. With fixed_ball_mm the machine error remains.
  SynthOptions o;
  o.centre_err_um[0] = 3.0;
  o.centre_err_um[1] = 4.0;
  o.fixed_ball_err_um[0] = 20.0;
  o.fixed_ball_err_um[1] = -10.0;
  o.form_um = [](double th) { return 1.0 * std::sin(3 * th); };
  auto t = MakeTrace(o);
  const auto conv = AnalyzeCircularTest(t);
  EXPECT_EQ(conv.mode, Mode::kCentreCorrected);
  EXPECT_NEAR(conv.centre_offset_um[0], 3.0 - 20.0, 2e-3);
  EXPECT_NEAR(conv.centre_offset_um[1], 4.0 + 10.0, 2e-3);

  t.fixed_ball_mm = std::array<double, 3>{0.020, -0.010, 0.0};
  const auto abs = AnalyzeCircularTest(t);
  EXPECT_EQ(abs.mode, Mode::kAbsolute);
  EXPECT_NEAR(abs.centre_offset_um[0], 3.0, 2e-3);
  EXPECT_NEAR(abs.centre_offset_um[1], 4.0, 2e-3);
  ASSERT_TRUE(abs.radial_error_range_um.has_value());
  // About the fixed ball the 5 µm centre error shows as a 10 µm range (plus the 2 µm trefoil
  // at most).
  EXPECT_GT(*abs.radial_error_range_um, 10.0 - 1e-3);
  EXPECT_LT(*abs.radial_error_range_um, 12.0 + 1e-3);
  // The 22 µm fixed-ball offset adds a second-order term δ²/(2R) ≈ 0.0016 µm to the
  // conventional trace; that is physics, not a fit error.
  EXPECT_NEAR(abs.circularity_um, conv.circularity_um, 5e-3);
  EXPECT_NEAR(abs.circularity_um, 2.0, 2e-3);
}

TEST(CircularTest, ConeTestHonoursRadiusAndBarLength) {
  // [PM-600 report] §4.2.4: R = 144 mm, bar 150 mm, moving-ball plane 42 mm above the fixed ball.
  SynthOptions o;
  o.radius_mm = 144.0;
  o.bar_mm = 150.0;
  o.z_offset_mm = 42.0;
  o.centre_err_um[0] = 10.0;
  o.radius_err_um = 5.0;
  auto t = MakeTrace(o);
  const auto r = AnalyzeCircularTest(t);
  // A radial error e of the moving ball changes the bar by (R / R_DBB)·e on the cone.
  const double k = 144.0 / 150.0;
  EXPECT_NEAR(r.centre_offset_um[0], 10.0 * k, 2e-3);
  EXPECT_NEAR(r.average_radial_error_um, 5.0 * k, 2e-3);
  EXPECT_LT(r.circularity_um, 2e-3);
  t.fixed_ball_mm = std::array<double, 3>{0, 0, 0};
  const auto a = AnalyzeCircularTest(t);
  ASSERT_TRUE(a.machine_centre_error_um.has_value());
  EXPECT_NEAR((*a.machine_centre_error_um)[0], 10.0, 2e-3);
}

TEST(CircularTest, EvaluatesExactlyOneTurnOfALongerTrace) {
  // Rows from −45° to 405° (lead-in and lead-out arcs of 45°); a disturbance in the lead-in
  // must not reach the figures.
  SynthOptions o;
  o.start_deg = -45.0;
  o.span_deg = 450.0;
  o.samples = 4500;
  o.form_um = [](double th) { return 2.0 * std::cos(2 * th); };
  auto t = MakeTrace(o);
  for (std::size_t i = 0; i < 100; ++i) t.dr_um[i] += 50.0;  // −45° … −35°
  const auto r = AnalyzeCircularTest(t);
  EXPECT_NEAR(r.turn_start_deg, 0.0, 1e-9);
  EXPECT_NEAR(r.turn_end_deg, 360.0, 1e-9);
  EXPECT_EQ(r.sample_count, 3600u);
  EXPECT_NEAR(r.circularity_um, 4.0, 1e-3);
}

TEST(CircularTest, RefusesLessThanAFullTurn) {
  // Changed deliberately (partial arcs): a trace that does not come back to its
  // start is now a partial arc unless the file declares a full turn, so the 300° trace is
  // refused when it declares arc_deg 360, and a trace too short for a partial arc (150°) is
  // refused either way.
  SynthOptions o;
  o.span_deg = 300.0;
  o.samples = 300;
  auto t = MakeTrace(o);
  t.arc_deg = 360.0;
  EXPECT_THROW(AnalyzeCircularTest(t), InvalidInput);
  o.span_deg = 150.0;
  o.samples = 150;
  EXPECT_THROW(AnalyzeCircularTest(MakeTrace(o)), InvalidInput);
}

TEST(CircularTest, RefusesAnglesAgainstTheDirection) {
  SynthOptions o;
  auto t = MakeTrace(o);
  t.direction = Direction::kCw;  // angles increase, but the test says cw
  EXPECT_THROW(AnalyzeCircularTest(t), InvalidInput);
}

TEST(CircularTest, NoiseOnlyCircularityIsBoundedByTheNoise) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    SynthOptions o;
    o.noise_um = 0.2;
    o.seed = seed;
    const auto r = AnalyzeCircularTest(MakeTrace(o));
    // The range of 3600 Gaussian samples lies between about 6σ and 9σ.
    EXPECT_GT(r.circularity_um, 5 * 0.2);
    EXPECT_LT(r.circularity_um, 10 * 0.2);
    EXPECT_NEAR(r.fit_rms_um, 0.2, 0.02);
  }
}

}  // namespace
}  // namespace km::dbb
