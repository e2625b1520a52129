// Recover-the-truth tests of the multilateration self-calibration ([Tracker paper] set-up).
#include <gtest/gtest.h>

#include <ceres/ceres.h>
#include <ceres/covariance.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "analysis/core/errors.h"
#include "analysis/tracker/selfcal_normal.h"
#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_sim.h"
#include "tests/unit/tracker/tracker_test_util.h"

namespace km::tracker {
namespace {

using test::Accuracy;
using test::Evaluate;
using test::MakeSetup;

// Tolerances (0.2 µm reading noise, 4 trackers 0.6–1.2 m away, injected errors of a few µm):
//  - volumetric error: RMS over all components of (estimate − truth) < 0.5 µm;
//  - the predicted uncertainty matches the achieved RMS within a factor of 2;
//  - trackers (gauge frame): every component within 4.5 predicted σ. Their absolute accuracy is
//    set by the geometry: the distance of a far tracker to a small volume is almost
//    interchangeable with its dead path (only the curvature of the wavefront, ~θ²/2 with θ the
//    half-angle of the volume seen from the tracker, tells them apart). 1σ is 100–450 µm for the
//    100 mm cube and 3–15 µm for the 400 mm volume at 0.6–1.2 m; the volumetric errors do
//    not suffer from it.

// Condition number of the tracker parameters and point 1 (the zero of every tracker) with the
// other points eliminated, computed here independently of ComputeCovariance: the Jacobian of
// every reading |u_i − U_j| − |u_1 − U_j| (i > 1) at the solution (columns: the tracker
// components free in the gauge of docs/formats.md §3 — tracker 2: x, tracker 3: x, y, the others
// x, y, z — and the three coordinates of point 1), projected point by point onto the orthogonal
// complement of the point's own columns (QR), then the ratio of extreme singular values (SVD).
// This equals sqrt(lambda_max / lambda_min) of the Schur complement.
double IndependentConditionNumber(const SelfCalResult& r, const TrackerReadings& readings) {
  const int n = readings.NumTrackers();
  std::vector<std::array<int, 3>> col(static_cast<std::size_t>(n), {-1, -1, -1});
  int c = 0;
  for (int j = 1; j < n; ++j) {
    for (int a = 0; a < std::min(j, 3); ++a) col[static_cast<std::size_t>(j)][a] = c++;
  }
  const int first_point = c;
  c += 3;
  std::vector<Eigen::MatrixXd> blocks;
  Eigen::Index rows = 0;
  const Eigen::Vector3d& u1 = r.points_mm[0];
  for (int i = 1; i < readings.NumPoints(); ++i) {
    std::vector<int> seen;
    for (int j = 0; j < n; ++j)
      if (std::isfinite(readings.displacement_um(i, j))) seen.push_back(j);
    const auto k = static_cast<Eigen::Index>(seen.size());
    Eigen::MatrixXd jp(k, 3), jc = Eigen::MatrixXd::Zero(k, c);
    for (Eigen::Index q = 0; q < k; ++q) {
      const auto j = static_cast<std::size_t>(seen[static_cast<std::size_t>(q)]);
      const Eigen::Vector3d u =
          (r.points_mm[static_cast<std::size_t>(i)] - r.trackers_mm[j]).normalized();
      const Eigen::Vector3d z = (u1 - r.trackers_mm[j]).normalized();
      jp.row(q) = u.transpose();
      for (int a = 0; a < 3; ++a) {
        if (col[j][a] >= 0) jc(q, col[j][a]) = z(a) - u(a);
        jc(q, first_point + a) = -z(a);
      }
    }
    blocks.push_back(jc - jp * jp.colPivHouseholderQr().solve(jc));
    rows += k;
  }
  Eigen::MatrixXd m(rows, c);
  Eigen::Index at = 0;
  for (const auto& b : blocks) {
    m.middleRows(at, b.rows()) = b;
    at += b.rows();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(m);
  return svd.singularValues()(0) / svd.singularValues()(c - 1);
}

TEST(TrackerSelfCal, Cube100mmSimultaneous) {
  for (unsigned seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    const auto o = MakeSetup(100.0, 7, 4, seed);
    const auto sim = SimulateTrackerSurvey(o);
    const auto r = SelfCalibrate(sim.readings);
    const Accuracy a = Evaluate(o, sim, r);
    EXPECT_EQ(a.valid_points, 343);
    EXPECT_LT(a.volumetric_rms_um, 0.5);
    EXPECT_GT(a.volumetric_rms_um, 0.5 * a.predicted_rms_um);
    EXPECT_LT(a.volumetric_rms_um, 2.0 * a.predicted_rms_um);
    EXPECT_LT(a.tracker_max_sigmas, 4.5);
    EXPECT_NEAR(r.residual_rms_um,
                0.2 * std::sqrt(1.0 * (r.readings_used - r.unknowns) / r.readings_used), 0.03);
    EXPECT_TRUE(r.rejected.empty());
    EXPECT_TRUE(r.warnings.empty());
    // Gauge of docs/formats.md §3.
    EXPECT_EQ(r.trackers_mm[0].norm(), 0.0);
    EXPECT_EQ(r.trackers_mm[1].y(), 0.0);
    EXPECT_EQ(r.trackers_mm[1].z(), 0.0);
    EXPECT_GT(r.trackers_mm[1].x(), 0.0);
    EXPECT_EQ(r.trackers_mm[2].z(), 0.0);
    EXPECT_GT(r.trackers_mm[2].y(), 0.0);
    EXPECT_GT(r.trackers_mm[3].z(), 0.0);
    ASSERT_EQ(r.dead_path_mm.size(), 4u);  // one segment a tracker (no beam break), zeroed at
    EXPECT_EQ(r.dead_path_zero_row, std::vector<int>(4, 0));  // point 1
    EXPECT_NEAR(r.condition_number, IndependentConditionNumber(r, sim.readings),
                1e-6 * r.condition_number);
  }
}

TEST(TrackerSelfCal, Volume400mmSimultaneous) {
  for (unsigned seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    const auto o = MakeSetup(400.0, 5, 4, seed);
    const auto sim = SimulateTrackerSurvey(o);
    const auto r = SelfCalibrate(sim.readings);
    const Accuracy a = Evaluate(o, sim, r);
    EXPECT_LT(a.volumetric_rms_um, 0.5);
    EXPECT_LT(a.volumetric_rms_um, 2.0 * a.predicted_rms_um);
    EXPECT_GT(a.volumetric_rms_um, 0.5 * a.predicted_rms_um);
    EXPECT_LT(a.tracker_max_sigmas, 4.5);
    EXPECT_LT(a.tracker_max_um, 30.0);
  }
}

TEST(TrackerSelfCal, NearTrackersMeetFiveMicrons) {
  // Trackers 0.6–0.7 m from a 400 mm volume, 6 stations: tracker positions within 5 µm.
  for (unsigned seed : {4u, 5u}) {
    SCOPED_TRACE(seed);
    auto o = MakeSetup(400.0, 6, 6, seed);
    o.trackers_mm = PlaceTrackers({300, 200, 250}, 6, 600, 700, seed);
    const auto sim = SimulateTrackerSurvey(o);
    const auto r = SelfCalibrate(sim.readings);
    const Accuracy a = Evaluate(o, sim, r);
    EXPECT_LT(a.tracker_max_um, 5.0);
    EXPECT_LT(a.volumetric_rms_um, 0.5);
  }
}

TEST(TrackerSelfCal, SequentialStations) {
  // One tracker moved to 4 and to 6 stations; the machine repeats the points per station with
  // 0.1 µm repeatability; each station is zeroed at point 1.
  for (int stations : {4, 6}) {
    for (unsigned seed : {7u, 8u}) {
      SCOPED_TRACE(std::to_string(stations) + " stations, seed " + std::to_string(seed));
      auto o = MakeSetup(400.0, 5, stations, seed);
      o.mode = TrackerMode::kSequential;
      o.repeatability_um = 0.1;
      const auto sim = SimulateTrackerSurvey(o);
      const auto r = SelfCalibrate(sim.readings);
      EXPECT_EQ(r.mode, TrackerMode::kSequential);
      EXPECT_EQ(r.dead_path_mm.size(), static_cast<std::size_t>(stations));
      const Accuracy a = Evaluate(o, sim, r);
      EXPECT_LT(a.volumetric_rms_um, 0.5);
      EXPECT_LT(a.tracker_max_sigmas, 4.5);
      EXPECT_TRUE(r.rejected.empty());
    }
  }
}

std::set<std::pair<int, int>> Rejected(const SelfCalResult& r) {
  std::set<std::pair<int, int>> out;
  for (const auto& x : r.rejected) out.insert({x.row, x.tracker});
  return out;
}

TEST(TrackerSelfCal, GrossOutliersFourTrackersDropTheirPoints) {
  // 2 % of the readings ±50 µm. With 4 trackers a point has one redundant reading, so the
  // outlier cannot be pinned on a tracker: every reading of such a point is rejected.
  for (unsigned seed : {11u, 12u, 13u}) {
    SCOPED_TRACE(seed);
    auto o = MakeSetup(400.0, 6, 4, seed);
    o.outlier_fraction = 0.02;
    const auto sim = SimulateTrackerSurvey(o);
    ASSERT_GT(sim.outliers.size(), 10u);
    const auto r = SelfCalibrate(sim.readings);
    const auto rej = Rejected(r);
    // Two gross errors on one point can cancel in its single redundant reading (seed 12, row
    // 126: its readings fit to 0.19 µm): no reading shows them, so nothing may be rejected
    // there. The spatial check names such a point (a warning; the point is kept) and it is left
    // out of the accuracy below.
    std::set<int> named;
    for (const auto& x : r.spatial_outliers) named.insert(x.row);
    std::set<int> bad_rows, outlier_rows;
    for (const auto& [row, t] : sim.outliers) outlier_rows.insert(row);
    for (const auto& [row, t] : sim.outliers) {
      if (named.count(row)) {
        EXPECT_TRUE(r.point_valid[static_cast<std::size_t>(row)]);
        continue;
      }
      EXPECT_TRUE(rej.count({row, t})) << "row " << row << " tracker " << t;
      EXPECT_FALSE(r.point_valid[static_cast<std::size_t>(row)]);
      bad_rows.insert(row);
    }
    for (int row : named) EXPECT_TRUE(outlier_rows.count(row)) << "named clean row " << row;
    EXPECT_LE(named.size(), 1u);
    int dropped = 0;
    for (char v : r.point_valid) dropped += v == 0;
    EXPECT_LE(dropped, static_cast<int>(bad_rows.size()) + 2);  // ≤ 2 false alarms
    SelfCalResult checked = r;
    for (int row : named) checked.point_valid[static_cast<std::size_t>(row)] = 0;
    const Accuracy a = Evaluate(o, sim, checked);
    EXPECT_LT(a.volumetric_rms_um, 0.5);
    EXPECT_LT(a.tracker_max_sigmas, 4.5);
    // A point caught by its residuals stands far out (all its readings are rejected, the
    // largest standardised one well above noise).
    std::map<int, double> worst;
    for (const auto& x : r.rejected) {
      if (x.reason == "residual")
        worst[x.row] = std::max(worst[x.row], std::abs(x.standardised_um));
    }
    for (const auto& [row, z] : worst) EXPECT_GT(z, 1.0) << "row " << row;
    for (const auto& x : r.rejected) EXPECT_EQ(x.reason, "residual");
  }
}

TEST(TrackerSelfCal, GrossOutliersSixTrackersRejectTheReading) {
  for (unsigned seed : {21u, 22u}) {
    SCOPED_TRACE(seed);
    auto o = MakeSetup(400.0, 5, 6, seed);
    o.outlier_fraction = 0.02;
    const auto sim = SimulateTrackerSurvey(o);
    const auto r = SelfCalibrate(sim.readings);
    const auto rej = Rejected(r);
    for (const auto& ot : sim.outliers) EXPECT_TRUE(rej.count(ot));
    // Two gross errors on one point may be misattributed (all but 3 of its readings rejected).
    int dropped = 0;
    for (char v : r.point_valid) dropped += v == 0;
    EXPECT_LE(dropped, 2);
    EXPECT_LE(rej.size(), sim.outliers.size() + 3 + 6 * dropped);
    const Accuracy a = Evaluate(o, sim, r);
    EXPECT_LT(a.volumetric_rms_um, 0.5);
  }
}

TEST(TrackerSelfCal, SixTrackersTwoGrossErrorsOnOnePoint) {
  // Surveys where one point carries two of the gross errors. With 6 readings (3 redundant) the
  // other trackers' view of the point pins them (leave-one-out, then leave-two-out re-estimates
  // of the point); should two different pairs explain the readings equally well, the point is
  // dropped. A gross error is never left in a point that is kept, and single gross errors are
  // never attributed to a good reading (a robust pass may settle a point in the wrong place).
  for (unsigned seed : {13u, 15u, 24u, 25u, 28u, 40u}) {
    SCOPED_TRACE(seed);
    auto o = MakeSetup(400.0, 6, 6, seed);
    o.outlier_fraction = 0.02;
    const auto sim = SimulateTrackerSurvey(o);
    std::map<int, int> per_row;
    for (const auto& [row, t] : sim.outliers) ++per_row[row];
    const auto r = SelfCalibrate(sim.readings);
    const auto rej = Rejected(r);
    for (const auto& ot : sim.outliers) {
      EXPECT_TRUE(rej.count(ot) || !r.point_valid[static_cast<std::size_t>(ot.first)])
          << "row " << ot.first << " tracker " << ot.second;
    }
    std::size_t wrong = 0;
    for (const auto& x : rej) {
      if (per_row[x.first] == 1 && !std::count(sim.outliers.begin(), sim.outliers.end(), x)) {
        ++wrong;
      }
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_TRUE(r.spatial_outliers.empty());
    const Accuracy a = Evaluate(o, sim, r);
    EXPECT_LT(a.volumetric_rms_um, 0.5);
  }
}

TEST(TrackerSelfCal, BeamBreakStartsANewSegment) {
  // Tracker 2 re-zeroed at point row 40, tracker 4 elsewhere from row 90 (a dead path).
  auto o = MakeSetup(400.0, 5, 4, 31);
  o.beam_breaks = {{1, 40, false}, {3, 90, true}};
  const auto sim = SimulateTrackerSurvey(o);
  const auto r = SelfCalibrate(sim.readings);
  EXPECT_EQ(r.dead_path_mm.size(), 6u);
  EXPECT_EQ(r.dead_path_zero_row, (std::vector<int>{0, 0, 40, 0, 0, -1}));
  const Accuracy a = Evaluate(o, sim, r);
  EXPECT_LT(a.volumetric_rms_um, 0.5);
  // Ignoring the breaks must fit far worse (the readings jump by the new zero).
  auto no_break = sim.readings;
  no_break.beam_breaks.clear();
  SelfCalOptions opt;
  opt.reject_outliers = false;
  bool refused = false;
  double rms = 0;
  try {
    rms = SelfCalibrate(no_break, opt).residual_rms_um;
  } catch (const km::Error&) {
    refused = true;
  }
  EXPECT_TRUE(refused || rms > 20 * r.residual_rms_um) << rms;
}

TEST(TrackerSelfCal, GuessesAndAutomaticStartAgree) {
  auto o = MakeSetup(400.0, 5, 4, 41);
  auto sim = SimulateTrackerSurvey(o);
  const auto automatic = SelfCalibrate(sim.readings);
  std::mt19937 rng(41);
  std::normal_distribution<double> g(0.0, 30.0);
  for (int j = 0; j < 4; ++j) {
    TrackerGuess guess;
    guess.tracker = j;
    guess.position_mm =
        o.trackers_mm[static_cast<std::size_t>(j)] + Eigen::Vector3d(g(rng), g(rng), g(rng));
    sim.readings.guesses.push_back(guess);
  }
  const auto guessed = SelfCalibrate(sim.readings);
  for (int j = 0; j < 4; ++j) {
    EXPECT_LT((automatic.trackers_mm[static_cast<std::size_t>(j)] -
               guessed.trackers_mm[static_cast<std::size_t>(j)])
                  .norm(),
              1e-4);
  }
  EXPECT_NEAR(automatic.residual_rms_um, guessed.residual_rms_um, 1e-6);
}

TEST(TrackerSelfCal, RefusesThreeTrackers) {
  auto o = MakeSetup(100.0, 5, 4, 51);
  o.trackers_mm.resize(3);
  const auto sim = SimulateTrackerSurvey(o);
  try {
    SelfCalibrate(sim.readings);
    FAIL() << "expected NotObservable";
  } catch (const NotObservable& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("n·(m − 1) ≥ 3m + 3n − 6"), std::string::npos) << msg;
    EXPECT_NE(msg.find("m = 125, n = 3"), std::string::npos) << msg;
    // 3 · 124 readings (the zeros at point 1 are none), 375 + 9 − 6 unknowns.
    EXPECT_NE(msg.find("372 readings < 378 unknowns"), std::string::npos) << msg;
  }
}

TEST(TrackerSelfCal, RefusesTooFewPoints) {
  // The 8 corners of [Tracker paper]'s cube with 4 trackers: 4 · 7 = 28 readings (point 1 is
  // every tracker's zero), 24 + 12 − 6 = 30 unknowns.
  auto o = MakeSetup(100.0, 2, 4, 52);
  const auto sim = SimulateTrackerSurvey(o);
  try {
    SelfCalibrate(sim.readings);
    FAIL() << "expected NotObservable";
  } catch (const NotObservable& e) {
    EXPECT_NE(std::string(e.what()).find("28 readings < 30 unknowns"), std::string::npos)
        << e.what();
  }
  // 10 points are the minimum for 4 trackers (36 = 36): accepted by the counting rule, 9 are not.
  auto ten = MakeSetup(100.0, 3, 4, 52);
  ten.commanded_mm.resize(10);
  EXPECT_NO_THROW(
      SelfCalProblem::FromReadings(SimulateTrackerSurvey(ten).readings).CheckCounting());
  ten.commanded_mm.resize(9);
  EXPECT_THROW(SelfCalProblem::FromReadings(SimulateTrackerSurvey(ten).readings).CheckCounting(),
               NotObservable);
}

TEST(TrackerSelfCal, RefusesRankDeficientCollinearPoints) {
  // Points on one line: each tracker may turn about the line; the count is fine (76 ≥ 66).
  auto o = MakeSetup(100.0, 5, 4, 53);
  o.commanded_mm.clear();
  for (int i = 0; i < 20; ++i) o.commanded_mm.push_back({250.0 + 10.0 * i, 200.0, 250.0});
  const auto sim = SimulateTrackerSurvey(o);
  EXPECT_THROW(SelfCalibrate(sim.readings), NotObservable);
}

TEST(TrackerSelfCal, RefusesCoplanarTrackers) {
  // [Tracker paper]'s set-up: all four trackers on the table (one plane), target above. The
  // distances do not fix the configuration (one direction of tracker/dead-path parameters is free).
  auto o = MakeSetup(100.0, 5, 4, 54);
  o.trackers_mm = {{-400, -500, 0}, {700, -450, 0}, {650, 800, 0}, {-350, 750, 0}};
  const auto sim = SimulateTrackerSurvey(o);
  try {
    SelfCalibrate(sim.readings);
    FAIL() << "expected NotObservable";
  } catch (const NotObservable& e) {
    EXPECT_NE(std::string(e.what()).find("coplanar"), std::string::npos) << e.what();
  }
  // 100 mm out of the plane: solvable, but the predicted uncertainty says how poorly.
  o.trackers_mm[1].z() = 100;
  o.trackers_mm[3].z() = -100;
  const auto sim2 = SimulateTrackerSurvey(o);
  const auto r = SelfCalibrate(sim2.readings);
  const Accuracy a = Evaluate(o, sim2, r);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("nearly coplanar"), std::string::npos);
  EXPECT_GT(a.predicted_rms_um, 5.0);
  EXPECT_LT(a.volumetric_rms_um, 2.5 * a.predicted_rms_um);
}

// One reading of [Tracker paper] eq. (1) for ceres::Covariance: |u_i − U_j| − |u_1 − U_j| − d_ij.
struct EqOneReading {
  explicit EqOneReading(double d_mm) : d_mm_(d_mm) {}
  template <typename T>
  bool operator()(const T* const u, const T* const U, const T* const u1, T* residual) const {
    using std::sqrt;
    const T a = sqrt((u[0] - U[0]) * (u[0] - U[0]) + (u[1] - U[1]) * (u[1] - U[1]) +
                     (u[2] - U[2]) * (u[2] - U[2]));
    const T b = sqrt((u1[0] - U[0]) * (u1[0] - U[0]) + (u1[1] - U[1]) * (u1[1] - U[1]) +
                     (u1[2] - U[2]) * (u1[2] - U[2]));
    residual[0] = a - b - T(d_mm_);
    return true;
  }
  double d_mm_;
};

TEST(TrackerSelfCal, CovarianceMatchesCeres) {
  // Independent computation: ceres::Covariance on eq. (1) written here from the readings (the
  // readings of point 1 are its zeros and no residual), gauge of docs/formats.md §3 by manifolds.
  auto o = MakeSetup(400.0, 3, 4, 61);
  const auto sim = SimulateTrackerSurvey(o);
  SelfCalOptions opt;
  opt.reject_outliers = false;
  const auto r = SelfCalibrate(sim.readings, opt);
  auto points = r.points_mm;
  auto trackers = r.trackers_mm;
  ceres::Problem cp;
  for (int i = 1; i < sim.readings.NumPoints(); ++i) {
    for (int j = 0; j < 4; ++j) {
      cp.AddResidualBlock(new ceres::AutoDiffCostFunction<EqOneReading, 1, 3, 3, 3>(
                              new EqOneReading(1e-3 * sim.readings.displacement_um(i, j))),
                          nullptr, points[static_cast<std::size_t>(i)].data(),
                          trackers[static_cast<std::size_t>(j)].data(), points[0].data());
    }
  }
  cp.SetParameterBlockConstant(trackers[0].data());
  cp.SetManifold(trackers[1].data(), new ceres::SubsetManifold(3, {1, 2}));
  cp.SetManifold(trackers[2].data(), new ceres::SubsetManifold(3, {2}));
  ceres::Covariance::Options copt;
  copt.algorithm_type = ceres::SPARSE_QR;  // full rank: the gauge is fixed by manifolds
  ceres::Covariance cov(copt);
  std::vector<std::pair<const double*, const double*>> blocks;
  for (const auto& p : points) blocks.push_back({p.data(), p.data()});
  blocks.push_back({trackers[3].data(), trackers[3].data()});
  ASSERT_TRUE(cov.Compute(blocks, &cp));
  const double s2 = r.sigma_um * r.sigma_um;
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> C;
    cov.GetCovarianceBlock(points[i].data(), points[i].data(), C.data());
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(r.gauge_uncertainty_um[i](k), std::sqrt(s2 * C(k, k)),
                  1e-6 * std::sqrt(s2 * C(k, k)))
          << "point row " << i;
    }
  }
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> C4;
  cov.GetCovarianceBlock(trackers[3].data(), trackers[3].data(), C4.data());
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(r.tracker_uncertainty_um[3](k), std::sqrt(s2 * C4(k, k)),
                1e-6 * std::sqrt(s2 * C4(k, k)));
  }
}

TEST(TrackerSelfCal, JacobianOfTheSolveMatchesCentralDifferences) {
  // The hand-written Jacobian of the solve (selfcal_normal.h): its gradient Jᵀr and the diagonal
  // of JᵀJ against central differences of the residuals, at a state off the optimum, with a
  // re-zeroing at a point (a zero point among the global columns, also read by other trackers)
  // and one elsewhere (a dead path).
  auto o = MakeSetup(400.0, 3, 4, 62);
  o.beam_breaks = {{1, 9, false}, {2, 14, true}};
  const auto sim = SimulateTrackerSurvey(o);
  const SelfCalProblem problem = SelfCalProblem::FromReadings(sim.readings);
  SelfCalState state;
  for (const auto& u : o.trackers_mm)
    state.trackers_mm.push_back(u + Eigen::Vector3d(0.1, -0.2, 0.05));
  for (const auto& p : sim.true_points_mm)
    state.points_mm.push_back(p + Eigen::Vector3d(0.02, 0.01, -0.03));
  state.offsets_mm.assign(problem.segments.size(), 0.0);
  state.offsets_mm[4] = (state.points_mm[14] - state.trackers_mm[2]).norm() + 30.0;
  selfcal_normal::Gauge gauge;  // the tracker gauge
  const auto layout = selfcal_normal::MakeLayout(problem, gauge);
  ASSERT_EQ(layout.count, 6 + 3 + 3 + 1);  // trackers, points 1 and 10, one dead path
  selfcal_normal::NormalEquations ne;
  selfcal_normal::Build(problem, layout, state, nullptr, ne);
  // Every parameter of the layout: gradient Jᵀr and diagonal Σ(∂r/∂x)² against central
  // differences of the residuals.
  auto check = [&](double* x, double g, double diag, const std::string& what) {
    const double h = 1e-5, keep = *x;
    *x = keep + h;
    const auto rp = problem.ResidualsUm(state);
    *x = keep - h;
    const auto rm = problem.ResidualsUm(state);
    *x = keep;
    const auto r0 = problem.ResidualsUm(state);
    double g_fd = 0, diag_fd = 0;
    for (std::size_t k = 0; k < r0.size(); ++k) {
      if (!std::isfinite(r0[k])) continue;
      const double d = (rp[k] - rm[k]) / (2 * h);
      g_fd += d * r0[k];
      diag_fd += d * d;
    }
    EXPECT_NEAR(g, g_fd, 1e-6 * std::max(1.0, std::abs(g))) << what;
    EXPECT_NEAR(diag, diag_fd, 1e-6 * diag) << what;
  };
  for (int j = 0; j < 4; ++j) {
    for (int a = 0; a < 3; ++a) {
      const int col =
          layout.tracker_column[static_cast<std::size_t>(j)][static_cast<std::size_t>(a)];
      if (col >= 0)
        check(&state.trackers_mm[static_cast<std::size_t>(j)](a), ne.g(col), ne.F(col, col),
              "tracker " + std::to_string(j));
    }
  }
  for (std::size_t i = 0; i < state.points_mm.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      const int e = layout.eliminated[i];
      const int col = layout.point_column[i][static_cast<std::size_t>(a)];
      if (e >= 0) {
        check(&state.points_mm[i](a), ne.g_points(3 * e + a),
              ne.A[static_cast<std::size_t>(e)](a, a), "point " + std::to_string(i));
      } else {
        ASSERT_GE(col, 0);
        check(&state.points_mm[i](a), ne.g(col), ne.F(col, col), "zero point " + std::to_string(i));
      }
    }
  }
  const int col = layout.offset_column[4];
  ASSERT_GE(col, 0);
  check(&state.offsets_mm[4], ne.g(col), ne.F(col, col), "dead path");
}

TEST(TrackerSelfCal, OptionsAreChecked) {
  SelfCalOptions o;
  o.outlier_k = 0.5;
  EXPECT_THROW(o.Check(), InvalidInput);
}

}  // namespace
}  // namespace km::tracker
