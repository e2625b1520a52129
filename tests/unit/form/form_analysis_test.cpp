// Straightness, periodic components, reversal, flatness and parallelism: synthetic
// recover-the-truth tests with seeded noise ([Fujita thesis] fig. 4.10 waviness, [Fujita thesis]
// ch. 8 lead error and set-up slope, [PM-600 report] fig. 2.4 flatness / parallelism set-ups).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "analysis/core/errors.h"
#include "analysis/form/flatness.h"
#include "analysis/form/parallelism.h"
#include "analysis/form/periodic.h"
#include "analysis/form/straightness.h"

namespace km::form {
namespace {

constexpr double kPi = std::numbers::pi;

// Positions start..start+length with mean spacing `step` and +-40 % jitter (non-uniform).
std::vector<double> JitteredPositions(std::mt19937& rng, double start, double length, double step) {
  std::uniform_real_distribution<double> j(-0.4 * step, 0.4 * step);
  std::vector<double> x;
  const int n = static_cast<int>(length / step) + 1;
  for (int i = 0; i < n; ++i) {
    double xi = start + i * step + ((i == 0 || i == n - 1) ? 0.0 : j(rng));
    x.push_back(xi);
  }
  return x;
}

TEST(Straightness, RecoversTheSlopeAndBoundsTheReferences) {
  for (unsigned seed : {101u, 102u, 103u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.05);
    Profile p;
    p.position_mm = JitteredPositions(rng, -50.0, 400.0, 1.0);
    const double slope_um_per_m = 37.0;
    for (double x : p.position_mm)
      p.deviation_um.push_back(1.5 + 1e-3 * slope_um_per_m * x + noise(rng));
    const StraightnessResult r = AnalyzeStraightness(p);
    // sigma = 0.05 um / sqrt(401 * 400^2 / 12) per mm = 0.022 um/m; 5 sigma.
    EXPECT_NEAR(r.slope_um_per_m, slope_um_per_m, 0.11);
    EXPECT_NEAR(r.min_zone_slope_um_per_m, slope_um_per_m, 1.0);
    EXPECT_EQ(r.reference, "least_squares_line");
    EXPECT_LE(r.straightness_min_zone_um, r.straightness_lsq_um + 1e-12);
    EXPECT_LE(r.straightness_min_zone_um, r.straightness_end_point_um + 1e-12);
    // Gaussian noise of 0.05 um over 401 points spans roughly 5.5 - 7 sigma.
    EXPECT_GT(r.straightness_lsq_um, 0.2);
    EXPECT_LT(r.straightness_lsq_um, 0.45);
    EXPECT_TRUE(r.periodic.empty())
        << "noise only, seed " << seed << ", found period " << r.periodic.front().period_mm;
    EXPECT_DOUBLE_EQ(r.length_mm, 400.0);
  }
}

TEST(Straightness, FindsGuideWavinessOf55mm) {
  // [Fujita thesis] fig. 4.10: capacitance sensor against an optical flat, 0.4 um P-V (amplitude
  // 0.2 um) waviness with a ~55 mm period; here in 0.02 um noise with a set-up slope.
  for (unsigned seed : {201u, 202u, 203u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.02);
    std::uniform_real_distribution<double> ph(0.0, 2.0 * kPi);
    const double phase = ph(rng);
    Profile p;
    p.position_mm = JitteredPositions(rng, -150.0, 300.0, 0.5);
    for (double x : p.position_mm) {
      p.deviation_um.push_back(0.012 * x + 0.2 * std::cos(2.0 * kPi * x / 55.0 - phase) +
                               noise(rng));
    }
    const StraightnessResult r = AnalyzeStraightness(p);
    ASSERT_EQ(r.periodic.size(), 1u) << "seed " << seed;
    EXPECT_NEAR(r.periodic[0].period_mm, 55.0, 0.02 * 55.0);
    EXPECT_NEAR(r.periodic[0].period_mm, 55.0, 0.3);  // achieved: well inside 2 %
    EXPECT_NEAR(r.periodic[0].amplitude_um, 0.2, 0.01);
    // r = A cos(2 pi x / P - phase); compare on the circle.
    EXPECT_NEAR(std::remainder(r.periodic[0].phase_rad - phase, 2.0 * kPi), 0.0, 0.05);
    EXPECT_LT(r.periodic[0].false_alarm_probability, 1e-6);
    EXPECT_NEAR(r.straightness_min_zone_um, 0.4, 0.1);
  }
}

TEST(Straightness, ABowIsNotReportedAsAPeriod) {
  // Smooth form (a 0.5 um bow of the guide) next to the 55 mm waviness: only the waviness is
  // periodic; without the waviness nothing is.
  for (unsigned seed : {211u, 212u}) {
    for (double wave : {0.2, 0.0}) {
      std::mt19937 rng(seed);
      std::normal_distribution<double> noise(0.0, 0.02);
      Profile p;
      p.position_mm = JitteredPositions(rng, 0.0, 300.0, 0.5);
      for (double x : p.position_mm) {
        p.deviation_um.push_back(2e-5 * (x - 150.0) * (x - 150.0) - 0.003 * x +
                                 wave * std::sin(2.0 * kPi * x / 55.0) + noise(rng));
      }
      const StraightnessResult r = AnalyzeStraightness(p);
      ASSERT_EQ(r.periodic.size(), wave > 0.0 ? 1u : 0u) << "seed " << seed << " wave " << wave;
      if (wave > 0.0) {
        EXPECT_NEAR(r.periodic[0].period_mm, 55.0, 0.02 * 55.0);
        EXPECT_NEAR(r.periodic[0].amplitude_um, wave, 0.01);
      }
    }
  }
}

TEST(Straightness, FindsBallScrewLeadOf10mmUnderASetUpSlope) {
  // [Fujita thesis] ch. 8: first-order slope (squareness + optical-flat set-up) plus a 10 mm
  // periodic error (ball-screw lead), sampled non-uniformly.
  for (unsigned seed : {301u, 302u, 303u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.02);
    Profile p;
    p.position_mm = JitteredPositions(rng, 0.0, 120.0, 0.25);
    const double slope_um_per_m = 85.0;
    for (double x : p.position_mm) {
      p.deviation_um.push_back(1e-3 * slope_um_per_m * x + 0.15 * std::sin(2.0 * kPi * x / 10.0) +
                               noise(rng));
    }
    const StraightnessResult r = AnalyzeStraightness(p);
    ASSERT_EQ(r.periodic.size(), 1u) << "seed " << seed;
    EXPECT_NEAR(r.periodic[0].period_mm, 10.0, 0.02 * 10.0);
    EXPECT_NEAR(r.periodic[0].amplitude_um, 0.15, 0.01);
    // 12 full sine cycles still bias the plain least-squares slope by -12 A P / (2 pi L^2)
    // = -0.2 um/m; the joint fit with the found component removes that bias
    // (sigma = 0.02 um / sqrt(481 * 120^2 / 12) per mm = 0.026 um/m; 5 sigma).
    EXPECT_NEAR(r.slope_um_per_m,
                slope_um_per_m - 12.0 * 0.15 * 10.0 / (2.0 * kPi * 120.0 * 120.0) * 1e3, 0.13);
    EXPECT_NEAR(r.slope_with_periodic_um_per_m, slope_um_per_m, 0.13);
  }
}

TEST(Straightness, SeparatesTwoPeriodicComponents) {
  for (unsigned seed : {401u, 402u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.02);
    Profile p;
    p.position_mm = JitteredPositions(rng, 0.0, 330.0, 0.5);
    for (double x : p.position_mm) {
      p.deviation_um.push_back(0.2 * std::cos(2.0 * kPi * x / 55.0) +
                               0.08 * std::sin(2.0 * kPi * x / 10.0 + 1.0) + noise(rng));
    }
    const StraightnessResult r = AnalyzeStraightness(p);
    ASSERT_EQ(r.periodic.size(), 2u) << "seed " << seed;
    EXPECT_NEAR(r.periodic[0].period_mm, 55.0, 0.02 * 55.0);
    EXPECT_NEAR(r.periodic[0].amplitude_um, 0.2, 0.01);
    EXPECT_NEAR(r.periodic[1].period_mm, 10.0, 0.02 * 10.0);
    EXPECT_NEAR(r.periodic[1].amplitude_um, 0.08, 0.01);
  }
}

TEST(Straightness, RejectsMalformedProfiles) {
  Profile p{{0.0, 1.0, 1.0, 2.0}, {0.0, 0.0, 0.0, 0.0}};
  EXPECT_THROW(AnalyzeStraightness(p), InvalidInput);
  Profile q{{0.0, 1.0}, {0.0, 0.0}};
  EXPECT_THROW(AnalyzeStraightness(q), NotObservable);
  Profile s{{0.0, 1.0, 2.0}, {0.0, 0.0}};
  EXPECT_THROW(AnalyzeStraightness(s), InvalidInput);
}

TEST(Reversal, SeparatesMachineAndArtefact) {
  for (unsigned seed : {501u, 502u, 503u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.01);
    const auto machine = [](double x) {
      return 0.5 * std::sin(2.0 * kPi * x / 120.0) + 2e-3 * x;  // carriage error
    };
    const auto artefact = [](double x) {
      return 0.3 * std::cos(2.0 * kPi * x / 35.0) - 4e-5 * (x - 100.0) * (x - 100.0);  // flat
    };
    Profile a, b;
    a.position_mm = JitteredPositions(rng, 0.0, 200.0, 1.0);
    b.position_mm = JitteredPositions(rng, -0.5, 201.0, 1.0);  // other positions, interpolated
    for (double x : a.position_mm) a.deviation_um.push_back(machine(x) + artefact(x) + noise(rng));
    for (double x : b.position_mm) b.deviation_um.push_back(machine(x) - artefact(x) + noise(rng));
    const ReversalResult r = SeparateReversal(a, b);
    ASSERT_EQ(r.positions_mm.size(), a.position_mm.size());
    double worst_m = 0.0, worst_a = 0.0;
    for (std::size_t i = 0; i < r.positions_mm.size(); ++i) {
      worst_m = std::max(worst_m, std::abs(r.machine_um[i] - machine(r.positions_mm[i])));
      worst_a = std::max(worst_a, std::abs(r.artefact_um[i] - artefact(r.positions_mm[i])));
    }
    // Noise 0.01 / sqrt(2) per value, plus linear interpolation of b (< 0.003 um).
    EXPECT_LT(worst_m, 0.035) << "seed " << seed;
    EXPECT_LT(worst_a, 0.035) << "seed " << seed;
    // Separated straightness against the truth's (least-squares P-V on the same positions).
    Profile mt{r.positions_mm, {}}, at{r.positions_mm, {}};
    for (double x : r.positions_mm) {
      mt.deviation_um.push_back(machine(x));
      at.deviation_um.push_back(artefact(x));
    }
    StraightnessOptions no_periodic;
    no_periodic.find_periodic = false;
    EXPECT_NEAR(r.machine_straightness_lsq_um,
                AnalyzeStraightness(mt, no_periodic).straightness_lsq_um, 0.05);
    EXPECT_NEAR(r.artefact_straightness_lsq_um,
                AnalyzeStraightness(at, no_periodic).straightness_lsq_um, 0.05);
    EXPECT_NEAR(r.machine_slope_um_per_m, AnalyzeStraightness(mt, no_periodic).slope_um_per_m, 0.5);
  }
}

// Truth for the two reversal set-ups, written out here independently of straightness.cpp:
// machine (carriage) error M = bow + slope + 40 mm waviness, artefact error S = opposite bow +
// 17 mm waviness. The sensor of set-up a reads M + S. Set-up b: artefact turned over, sensor
// stays -> M - S; artefact turned over and sensor moved to the other side -> -M + S.
double TrueMachine(double x) {
  return 4e-5 * (x - 100.0) * (x - 100.0) + 1.5e-3 * x + 0.15 * std::sin(2.0 * kPi * x / 40.0);
}
double TrueArtefact(double x) {
  return -2.5e-5 * (x - 100.0) * (x - 100.0) + 0.08 * std::cos(2.0 * kPi * x / 17.0 + 0.3);
}
double SetupBReading(ReversalSetup setup, double x) {
  return setup == ReversalSetup::kArtefact ? TrueMachine(x) - TrueArtefact(x)
                                           : -TrueMachine(x) + TrueArtefact(x);
}

struct RecoveryError {
  double machine_um = 0.0, artefact_um = 0.0;  // largest |separated - truth|
};

RecoveryError SimulateAndSeparate(ReversalSetup setup, unsigned seed, double noise_um,
                                  ReversalSetup assumed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  Profile a, b;
  a.position_mm = JitteredPositions(rng, 0.0, 200.0, 1.0);
  b.position_mm = JitteredPositions(rng, -0.5, 201.0, 1.0);  // other positions, interpolated
  for (double x : a.position_mm) {
    a.deviation_um.push_back(TrueMachine(x) + TrueArtefact(x) + noise_um * noise(rng));
  }
  for (double x : b.position_mm) {
    b.deviation_um.push_back(SetupBReading(setup, x) + noise_um * noise(rng));
  }
  const ReversalResult r = SeparateReversal(a, b, assumed);
  EXPECT_EQ(r.setup, assumed);
  EXPECT_EQ(r.positions_mm.size(), a.position_mm.size());
  RecoveryError e;
  for (std::size_t i = 0; i < r.positions_mm.size(); ++i) {
    const double x = r.positions_mm[i];
    e.machine_um = std::max(e.machine_um, std::abs(r.machine_um[i] - TrueMachine(x)));
    e.artefact_um = std::max(e.artefact_um, std::abs(r.artefact_um[i] - TrueArtefact(x)));
  }
  return e;
}

TEST(Reversal, RecoversTheTruthForBothSetUps) {
  for (ReversalSetup setup : {ReversalSetup::kArtefact, ReversalSetup::kArtefactAndSensor}) {
    const std::string name = ReversalSetupName(setup);
    // Without noise only the linear interpolation of b is left (< 0.002 um here).
    const RecoveryError exact = SimulateAndSeparate(setup, 511u, 0.0, setup);
    std::printf("[ measured ] %s, no noise: machine %.2e um, artefact %.2e um\n", name.c_str(),
                exact.machine_um, exact.artefact_um);
    EXPECT_LT(exact.machine_um, 0.01) << name;
    EXPECT_LT(exact.artefact_um, 0.01) << name;
    // Noise 0.02 um a reading: 0.014 um a separated value, worst of ~200 below 0.07 um.
    for (unsigned seed : {521u, 522u, 523u}) {
      const RecoveryError noisy = SimulateAndSeparate(setup, seed, 0.02, setup);
      std::printf("[ measured ] %s, noise 0.02 um, seed %u: machine %.4f um, artefact %.4f um\n",
                  name.c_str(), seed, noisy.machine_um, noisy.artefact_um);
      EXPECT_LT(noisy.machine_um, 0.07) << name << " seed " << seed;
      EXPECT_LT(noisy.artefact_um, 0.07) << name << " seed " << seed;
    }
  }
  // The wrong set-up swaps machine and artefact (what data of the sensor-reversed set-up got before
  // reversal_setup): the errors are then of the size of the two profiles themselves.
  const RecoveryError wrong =
      SimulateAndSeparate(ReversalSetup::kArtefactAndSensor, 511u, 0.0, ReversalSetup::kArtefact);
  EXPECT_GT(wrong.machine_um, 0.3);
  EXPECT_GT(wrong.artefact_um, 0.3);
}

TEST(Reversal, SetUpNamesAndConvention) {
  EXPECT_EQ(ReversalSetupName(ReversalSetup::kArtefact), "artefact");
  EXPECT_EQ(ReversalSetupName(ReversalSetup::kArtefactAndSensor), "artefact_and_sensor");
  EXPECT_EQ(ParseReversalSetup("artefact_and_sensor"), ReversalSetup::kArtefactAndSensor);
  EXPECT_THROW(ParseReversalSetup("sensor"), InvalidInput);
  Profile a{{0, 1, 2, 3}, {1, 2, 3, 4}}, b{{0, 1, 2, 3}, {0, 0, 0, 0}};
  EXPECT_EQ(SeparateReversal(a, b).convention, "a = machine + artefact, b = machine - artefact");
  EXPECT_EQ(SeparateReversal(a, b, ReversalSetup::kArtefactAndSensor).convention,
            "a = machine + artefact, b = -machine + artefact");
}

TEST(Reversal, NeedsOverlappingProfiles) {
  Profile a{{0, 1, 2, 3}, {0, 0, 0, 0}}, b{{10, 11, 12, 13}, {0, 0, 0, 0}};
  EXPECT_THROW(SeparateReversal(a, b), InvalidInput);
}

TEST(Flatness, RecoversThePlaneAndStatesItsReferences) {
  for (unsigned seed : {601u, 602u, 603u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.5);
    const double sx = 120.0, sy = -75.0, off = 14.0;  // um/m, um/m, um
    Grid g;
    for (int i = 0; i < 12; ++i) {
      for (int j = 0; j < 12; ++j) {
        g.x_mm.push_back(-190.0 + 380.0 * i / 11.0);
        g.y_mm.push_back(-190.0 + 380.0 * j / 11.0);
        g.z_um.push_back(off + 1e-3 * (sx * g.x_mm.back() + sy * g.y_mm.back()) + noise(rng));
      }
    }
    const FlatnessResult r = AnalyzeFlatness(g);
    // sigma_slope = 0.5 um / sqrt(144 * var) per mm ~ 0.3 um/m; 5 sigma.
    EXPECT_NEAR(r.plane.slope_x_um_per_m, sx, 1.5);
    EXPECT_NEAR(r.plane.slope_y_um_per_m, sy, 1.5);
    EXPECT_NEAR(r.plane.offset_um, off, 0.2);
    const auto [lo, hi] = std::minmax_element(g.z_um.begin(), g.z_um.end());
    EXPECT_DOUBLE_EQ(r.range_um, *hi - *lo);
    EXPECT_LE(r.flatness_min_zone_um, r.flatness_lsq_um + 1e-9);
    EXPECT_GT(r.flatness_min_zone_um, 2.0);  // 144 samples of 0.5 um noise span > 4 sigma
    EXPECT_LT(r.flatness_lsq_um, 4.5);
    EXPECT_EQ(r.reference, "least_squares_plane");
    EXPECT_EQ(r.range_reference, "datum");
  }
}

TEST(Flatness, EightPointTableCheckLikeSeed000) {
  // [PM-600 report] fig. 2.4(a): 8 points in X, Y = -260..260, distance to the table read with a
  // micrometer relative to (260, 260). A pure tilt has zero flatness but a large range.
  const std::vector<std::pair<double, double>> pts{
      {-260, -260}, {0, -260}, {260, -260}, {-260, 0}, {260, 0}, {-260, 260}, {0, 260}, {260, 260}};
  Grid g;
  for (const auto& [x, y] : pts) {
    g.x_mm.push_back(x);
    g.y_mm.push_back(y);
    g.z_um.push_back(0.25 * (x - 260.0) - 0.1 * (y - 260.0));  // 250 / -100 um/m tilt
  }
  FlatnessResult r = AnalyzeFlatness(g);
  EXPECT_NEAR(r.flatness_lsq_um, 0.0, 1e-9);
  EXPECT_NEAR(r.flatness_min_zone_um, 0.0, 1e-9);
  EXPECT_NEAR(r.range_um, 0.25 * 520 + 0.1 * 520, 1e-9);
  EXPECT_NEAR(r.plane.slope_x_um_per_m, 250.0, 1e-6);
  EXPECT_NEAR(r.plane.slope_y_um_per_m, -100.0, 1e-6);
  // A 20 um bump in the middle of one edge: the minimum zone is then set by it. Any plane p
  // takes at the edge's midpoint the mean of its values at the edge's ends, so the departures e
  // satisfy e_mid = 20 + (e_end1 + e_end2) / 2 >= 20 + min(e_end1, e_end2): no plane does better
  // than 20 um, and the tilted plane itself achieves it. The minimum zone is exactly 20 um.
  g.z_um[1] += 20.0;
  r = AnalyzeFlatness(g);
  EXPECT_NEAR(r.flatness_min_zone_um, 20.0, 1e-9);
  // Least squares, computed here from the normal equations of z = a + b x + c y.
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atz = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < g.z_um.size(); ++i) {
    const Eigen::Vector3d row(1.0, g.x_mm[i], g.y_mm[i]);
    ata += row * row.transpose();
    atz += row * g.z_um[i];
  }
  const Eigen::Vector3d abc = ata.ldlt().solve(atz);
  double lo = 0.0, hi = 0.0;
  for (std::size_t i = 0; i < g.z_um.size(); ++i) {
    const double e = g.z_um[i] - (abc[0] + abc[1] * g.x_mm[i] + abc[2] * g.y_mm[i]);
    lo = i == 0 ? e : std::min(lo, e);
    hi = i == 0 ? e : std::max(hi, e);
  }
  EXPECT_NEAR(r.flatness_lsq_um, hi - lo, 1e-9);
  EXPECT_LE(r.flatness_min_zone_um, r.flatness_lsq_um + 1e-9);
}

TEST(Parallelism, FullRangeSlopeAndLength) {
  for (unsigned seed : {701u, 702u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.3);
    Profile p;
    p.position_mm = JitteredPositions(rng, -190.0, 380.0, 10.0);
    const double slope_um_per_m = 50.0;  // 19 um over X380 like the jig result of [PM-600 report]
    for (double x : p.position_mm)
      p.deviation_um.push_back(3.0 + 1e-3 * slope_um_per_m * x + noise(rng));
    const ParallelismResult r = AnalyzeParallelism(p);
    const auto [lo, hi] = std::minmax_element(p.deviation_um.begin(), p.deviation_um.end());
    EXPECT_DOUBLE_EQ(r.parallelism_um, *hi - *lo);
    EXPECT_DOUBLE_EQ(r.length_mm, 380.0);
    // sigma = 0.3 / sqrt(39 * 380^2 / 12) per mm ~ 0.44 um/m; 5 sigma.
    EXPECT_NEAR(r.slope_um_per_m, slope_um_per_m, 2.2);
    EXPECT_NEAR(r.parallelism_um, 19.0, 2.5);
    EXPECT_EQ(r.reference, "datum");
  }
}

TEST(Periodic, OptionsAreChecked) {
  PeriodicOptions o;
  o.oversampling = 0.5;
  EXPECT_THROW(o.Check(), InvalidInput);
  o = {};
  o.min_period_mm = 10.0;
  o.max_period_mm = 5.0;
  EXPECT_THROW(o.Check(), InvalidInput);
}

}  // namespace
}  // namespace km::form
