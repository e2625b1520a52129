// The self-calibration solves [Tracker paper] eq. (1) exactly:
//
//   d_ij = |u_i − U_j| − |u_z − U_j|,
//
// z the point tracker j was zeroed at (point 1, or the point of a beam break re-zeroed there);
// the reading at z is 0 by definition and no observation. Only a break re-zeroed elsewhere
// brings an unknown dead path L in place of |u_z − U_j|.
//
// The optimum is computed here by a dense Gauss–Newton iteration written for this test, in the
// paper's own parametrisation p = [U2 U3 V3 U4 V4 W4 … u1ᵀ … umᵀ (L …)] (U1 = 0, U2 on +x, U3 in
// the xy-plane: the gauge of docs/formats.md §3), with a dense Jacobian, started from the truth.
// It shares no code with analysis/tracker (the simulator aside); its gauge, its
// parametrisation and its rigid fit differ from the product's (point gauge, Schur-complement
// Levenberg–Marquardt). Surveys: simultaneous and sequential, 100 and 400 mm cubes, trackers
// near (0.55–0.8 m) and far (1.5–2.5 m), 0.15 µm reading noise, the first point exact.
//
// Tolerances: volumetric errors, points and tracker positions within 0.05 µm of the optimum (in
// practice ~1e-6 µm); against the truth, the volumetric errors' RMS within 0.5–2× the RMS the
// solver predicts (position_uncertainty_um) and every tracker coordinate within 4.5 predicted σ.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/SVD>

#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_sim.h"
#include "tests/unit/tracker/tracker_test_util.h"

namespace km::tracker {
namespace {

// ---------------------------------------------------------------------------------------------
// The reference: dense Gauss–Newton on eq. (1) in the paper's parametrisation.

struct Optimum {
  std::vector<Eigen::Vector3d> trackers_mm;  // gauge of docs/formats.md §3
  std::vector<Eigen::Vector3d> points_mm;
  std::vector<double> dead_paths_mm;  // per break re-zeroed elsewhere, in file order
  double cost_um2 = 0.0;
  double last_step_mm = 0.0;
};

// Where each reading's zero is: the row of the point (or −1 and the index of its dead path).
struct Zero {
  int row = 0;
  int dead_path = -1;
};

std::vector<std::vector<Zero>> ZerosOf(const TrackerReadings& rd, int* dead_paths) {
  const int m = rd.NumPoints(), n = rd.NumTrackers();
  std::vector<std::vector<Zero>> z(static_cast<std::size_t>(m),
                                   std::vector<Zero>(static_cast<std::size_t>(n)));
  *dead_paths = 0;
  for (int j = 0; j < n; ++j) {
    Zero current{0, -1};
    for (int i = 0; i < m; ++i) {
      for (const auto& b : rd.beam_breaks) {
        if (b.tracker != j || static_cast<int>(b.row) != i) continue;
        current = b.elsewhere ? Zero{-1, (*dead_paths)++} : Zero{i, -1};
      }
      z[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = current;
    }
  }
  return z;
}

// Columns of the paper's p: tracker j's free coordinates (U1: none, U2: x, U3: x, y, others all).
int TrackerColumn(int j, int axis) {
  if (j == 0 || axis >= std::min(j, 3)) return -1;
  static const int first[] = {0, 0, 1, 3};
  return j < 4 ? first[j] + axis : 6 + 3 * (j - 4) + axis;
}

Optimum DenseGaussNewton(const TrackerReadings& rd, std::vector<Eigen::Vector3d> trackers,
                         std::vector<Eigen::Vector3d> points, std::vector<double> dead) {
  const int m = rd.NumPoints(), n = rd.NumTrackers();
  int nd = 0;
  const auto zeros = ZerosOf(rd, &nd);
  const int nt = 3 * n - 6, np = nt + 3 * m + nd;
  auto pack = [&]() {
    Eigen::VectorXd p(np);
    for (int j = 1; j < n; ++j) {
      for (int a = 0; a < 3; ++a) {
        if (TrackerColumn(j, a) >= 0)
          p(TrackerColumn(j, a)) = trackers[static_cast<std::size_t>(j)](a);
      }
    }
    for (int i = 0; i < m; ++i) p.segment<3>(nt + 3 * i) = points[static_cast<std::size_t>(i)];
    for (int q = 0; q < nd; ++q) p(nt + 3 * m + q) = dead[static_cast<std::size_t>(q)];
    return p;
  };
  auto unpack = [&](const Eigen::VectorXd& p) {
    for (int j = 1; j < n; ++j) {
      for (int a = 0; a < 3; ++a) {
        if (TrackerColumn(j, a) >= 0)
          trackers[static_cast<std::size_t>(j)](a) = p(TrackerColumn(j, a));
      }
    }
    for (int i = 0; i < m; ++i) points[static_cast<std::size_t>(i)] = p.segment<3>(nt + 3 * i);
    for (int q = 0; q < nd; ++q) dead[static_cast<std::size_t>(q)] = p(nt + 3 * m + q);
  };
  // The dense Jacobian (µm per mm) and the residuals (µm) of every reading but the zeros.
  auto evaluate = [&](Eigen::MatrixXd* J) {
    std::vector<double> r;
    std::vector<Eigen::VectorXd> rows;
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < n; ++j) {
        const Zero z = zeros[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
        if (z.row == i) continue;
        const Eigen::Vector3d& U = trackers[static_cast<std::size_t>(j)];
        const Eigen::Vector3d a = points[static_cast<std::size_t>(i)] - U;
        const double zero_mm = z.row >= 0 ? (points[static_cast<std::size_t>(z.row)] - U).norm()
                                          : dead[static_cast<std::size_t>(z.dead_path)];
        r.push_back(1e3 * (a.norm() - zero_mm) - rd.displacement_um(i, j));
        if (!J) continue;
        Eigen::VectorXd row = Eigen::VectorXd::Zero(np);
        const Eigen::Vector3d na = a.normalized();
        row.segment<3>(nt + 3 * i) += 1e3 * na;
        Eigen::Vector3d dU = -1e3 * na;
        if (z.row >= 0) {
          const Eigen::Vector3d nb = (points[static_cast<std::size_t>(z.row)] - U).normalized();
          row.segment<3>(nt + 3 * z.row) -= 1e3 * nb;
          dU += 1e3 * nb;
        } else {
          row(nt + 3 * m + z.dead_path) = -1e3;
        }
        for (int k = 0; k < 3; ++k) {
          if (TrackerColumn(j, k) >= 0) row(TrackerColumn(j, k)) += dU(k);
        }
        rows.push_back(row);
      }
    }
    if (J) {
      J->resize(static_cast<Eigen::Index>(rows.size()), np);
      for (std::size_t q = 0; q < rows.size(); ++q)
        J->row(static_cast<Eigen::Index>(q)) = rows[q].transpose();
    }
    return Eigen::VectorXd(
        Eigen::Map<const Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size())));
  };
  Optimum out;
  Eigen::MatrixXd J;
  Eigen::VectorXd r = evaluate(&J);
  for (int it = 0; it < 40; ++it) {
    // Gauss–Newton step from the normal equations, one step of iterative refinement; halved
    // while the sum of squares would grow.
    const Eigen::MatrixXd N = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(N);
    Eigen::VectorXd step = -ldlt.solve(g);
    step -= ldlt.solve(N * step + g);
    const Eigen::VectorXd p0 = pack();
    const double cost0 = r.squaredNorm();
    double t = 1.0;
    for (int halving = 0; halving < 30; ++halving, t *= 0.5) {
      unpack(p0 + t * step);
      if (evaluate(nullptr).squaredNorm() <= cost0 * (1 + 1e-15)) break;
    }
    r = evaluate(&J);
    out.last_step_mm = (t * step).cwiseAbs().maxCoeff();
    if (out.last_step_mm < 1e-11) break;
  }
  out.trackers_mm = trackers;
  out.points_mm = points;
  out.dead_paths_mm = dead;
  out.cost_um2 = r.squaredNorm();
  return out;
}

// The truth in the gauge of docs/formats.md §3 (a mirror image when tracker 4 is below the plane
// of trackers 1–3 as seen from their right-handed frame): the reference's start.
struct GaugeFrame {
  Eigen::Matrix3d R;
  Eigen::Vector3d origin;
  bool mirrored = false;
  Eigen::Vector3d Apply(const Eigen::Vector3d& x) const { return R * (x - origin); }
};

GaugeFrame FrameOf(const std::vector<Eigen::Vector3d>& U) {
  GaugeFrame f;
  const Eigen::Vector3d ex = (U[1] - U[0]).normalized();
  Eigen::Vector3d ey = U[2] - U[0];
  ey = (ey - ey.dot(ex) * ex).normalized();
  Eigen::Vector3d ez = ex.cross(ey);
  if (ez.dot(U[3] - U[0]) < 0) {
    ez = -ez;
    f.mirrored = true;
  }
  f.R.row(0) = ex;
  f.R.row(1) = ey;
  f.R.row(2) = ez;
  f.origin = U[0];
  return f;
}

// Volumetric errors of points given in the gauge frame: the points brought back to a proper
// frame, then the best proper rigid motion onto the commanded points (Kabsch).
std::vector<Eigen::Vector3d> VolumetricErrors(std::vector<Eigen::Vector3d> pts, bool mirrored,
                                              const std::vector<Eigen::Vector3d>& commanded) {
  if (mirrored) {
    for (auto& p : pts) p.z() = -p.z();
  }
  Eigen::Vector3d cp = Eigen::Vector3d::Zero(), cc = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < pts.size(); ++i) {
    cp += pts[i];
    cc += commanded[i];
  }
  cp /= static_cast<double>(pts.size());
  cc /= static_cast<double>(pts.size());
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < pts.size(); ++i) H += (pts[i] - cp) * (commanded[i] - cc).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d R = svd.matrixV() * D * svd.matrixU().transpose();
  std::vector<Eigen::Vector3d> e;
  for (std::size_t i = 0; i < pts.size(); ++i)
    e.push_back(1e3 * (R * (pts[i] - cp) + cc - commanded[i]));
  return e;
}

// ---------------------------------------------------------------------------------------------
// Surveys.

struct Kind {
  std::string name;
  TrackerMode mode;
  double size_mm;
  int per_axis;
  double near_mm, far_mm;
  unsigned seed;
};

std::vector<Kind> SixKinds() {
  std::vector<Kind> out;
  unsigned seed = 301;
  for (const auto mode : {TrackerMode::kSimultaneous, TrackerMode::kSequential}) {
    for (const double size : {100.0, 400.0}) {
      for (const bool far : {false, true}) {
        out.push_back({std::string(ModeName(mode)) + ", " + std::to_string(int(size)) +
                           " mm cube, " + (far ? "far" : "near") + " trackers",
                       mode, size, size < 200 ? 5 : 6, far ? 1500.0 : 550.0, far ? 2500.0 : 800.0,
                       seed++});
      }
    }
  }
  return out;
}

TrackerSimOptions SurveyOf(const Kind& k) {
  const Eigen::Vector3d centre(320, 180, 260);
  TrackerSimOptions o;
  o.seed = k.seed;
  o.commanded_mm = GridPoints(centre, k.size_mm, k.per_axis);
  o.trackers_mm = PlaceTrackers(centre, 4, k.near_mm, k.far_mm, k.seed);
  o.machine = test::FewMicronMachine(centre, k.size_mm);
  o.machine.periodic.push_back({0, 2, 1.5, 0.7 * k.size_mm, 0.4});
  o.mode = k.mode;
  o.noise_um = 0.15;
  if (k.mode == TrackerMode::kSequential) o.repeatability_um = 0.1;
  return o;
}

// The reference from the truth (trackers, points and dead paths in the gauge frame).
Optimum ReferenceFor(const TrackerSimOptions& o, const TrackerSimResult& sim) {
  const GaugeFrame f = FrameOf(o.trackers_mm);
  std::vector<Eigen::Vector3d> U, u;
  for (const auto& t : o.trackers_mm) U.push_back(f.Apply(t));
  for (const auto& p : sim.true_points_mm) u.push_back(f.Apply(p));
  std::vector<double> dead;
  for (const auto& b : sim.readings.beam_breaks) {
    if (!b.elsewhere) continue;
    const auto j = static_cast<std::size_t>(b.tracker);
    dead.push_back((u[b.row] - U[j]).norm() -
                   1e-3 * sim.readings.displacement_um(static_cast<long>(b.row), b.tracker));
  }
  return DenseGaussNewton(sim.readings, U, u, dead);
}

struct Agreement {
  double volumetric_um = 0, points_um = 0, trackers_um = 0;
};

Agreement Compare(const SelfCalResult& r, const Optimum& ref, const TrackerSimOptions& o) {
  Agreement a;
  const bool mirrored = FrameOf(o.trackers_mm).mirrored;
  const auto e_ref = VolumetricErrors(ref.points_mm, mirrored, o.commanded_mm);
  for (std::size_t i = 0; i < e_ref.size(); ++i) {
    a.volumetric_um =
        std::max(a.volumetric_um, (r.volumetric_error_um[i] - e_ref[i]).cwiseAbs().maxCoeff());
    a.points_um =
        std::max(a.points_um, 1e3 * (r.points_mm[i] - ref.points_mm[i]).cwiseAbs().maxCoeff());
  }
  for (std::size_t j = 0; j < ref.trackers_mm.size(); ++j) {
    a.trackers_um = std::max(a.trackers_um,
                             1e3 * (r.trackers_mm[j] - ref.trackers_mm[j]).cwiseAbs().maxCoeff());
  }
  return a;
}

// ---------------------------------------------------------------------------------------------

TEST(TrackerEqOne, ReferenceRecoversTheTruthWithoutNoise) {
  // The reference itself: noise-free readings give back the truth (to 0.1 nm: trackers 2.5 m
  // from a 100 mm cube), from a start 0.3 mm away.
  auto o = SurveyOf(SixKinds()[5]);
  o.noise_um = 0.0;
  o.repeatability_um = 0.0;
  const auto sim = SimulateTrackerSurvey(o);
  const GaugeFrame f = FrameOf(o.trackers_mm);
  std::vector<Eigen::Vector3d> U, u, U0, u0;
  for (const auto& t : o.trackers_mm) U.push_back(f.Apply(t));
  for (const auto& p : sim.true_points_mm) u.push_back(f.Apply(p));
  U0 = U;
  u0 = u;
  for (std::size_t j = 1; j < U0.size(); ++j)
    U0[j] += Eigen::Vector3d(0.3, j > 1 ? -0.2 : 0.0, j > 2 ? 0.25 : 0.0);
  for (std::size_t i = 0; i < u0.size(); ++i)
    u0[i] += 0.3 * Eigen::Vector3d(std::sin(i), std::cos(3.0 * i), std::sin(7.0 * i));
  const Optimum ref = DenseGaussNewton(sim.readings, U0, u0, {});
  EXPECT_LT(ref.cost_um2, 1e-12);
  for (std::size_t j = 0; j < U.size(); ++j)
    EXPECT_LT((ref.trackers_mm[j] - U[j]).norm(), 1e-7) << j;
  for (std::size_t i = 0; i < u.size(); ++i) EXPECT_LT((ref.points_mm[i] - u[i]).norm(), 1e-7) << i;
}

TEST(TrackerEqOne, SixKindsOfSurveyAtTheOptimumOfEquationOne) {
  for (const Kind& k : SixKinds()) {
    SCOPED_TRACE(k.name + ", seed " + std::to_string(k.seed));
    const auto o = SurveyOf(k);
    const auto sim = SimulateTrackerSurvey(o);
    const SelfCalResult r = SelfCalibrate(sim.readings);
    ASSERT_TRUE(r.rejected.empty());
    ASSERT_TRUE(r.warnings.empty()) << r.warnings.front();
    // The zero readings are no observations: 4 · (m − 1) readings, 3m + 6 unknowns.
    const auto m = static_cast<std::size_t>(sim.readings.NumPoints());
    EXPECT_EQ(r.readings_used, 4 * (m - 1));
    EXPECT_EQ(r.unknowns, 3 * m + 6);
    const Optimum ref = ReferenceFor(o, sim);
    ASSERT_LT(ref.last_step_mm, 1e-9);
    const Agreement a = Compare(r, ref, o);
    EXPECT_LT(a.volumetric_um, 0.05);
    EXPECT_LT(a.points_um, 0.05);
    EXPECT_LT(a.trackers_um, 0.05);
    std::printf("  %-45s optimum: volumetric %.2g, points %.2g, trackers %.2g um\n", k.name.c_str(),
                a.volumetric_um, a.points_um, a.trackers_um);
    // Against the truth: within what the solver predicts.
    const test::Accuracy acc = test::Evaluate(o, sim, r);
    EXPECT_LT(acc.volumetric_rms_um, 2.0 * acc.predicted_rms_um);
    EXPECT_GT(acc.volumetric_rms_um, 0.5 * acc.predicted_rms_um);
    EXPECT_LT(acc.tracker_max_sigmas, 4.5);
    std::printf("  %-45s truth: volumetric rms %.3f um (predicted %.3f), trackers %.1f sigma\n", "",
                acc.volumetric_rms_um, acc.predicted_rms_um, acc.tracker_max_sigmas);
  }
}

TEST(TrackerEqOne, BeamBreaksAtAPointAndElsewhere) {
  // Tracker 2 re-zeroed at point row 40 (eq. 1 from u_40 on, no unknown added); tracker 4 at a
  // place that is no surveyed point from row 90 on (one dead path).
  for (const auto mode : {TrackerMode::kSimultaneous, TrackerMode::kSequential}) {
    SCOPED_TRACE(ModeName(mode));
    auto o = SurveyOf({"", mode, 400.0, 6, 550.0, 800.0, 331});
    o.beam_breaks = {{1, 40, false}, {3, 90, true}};
    const auto sim = SimulateTrackerSurvey(o);
    ASSERT_EQ(sim.readings.displacement_um(40, 1), 0.0);
    ASSERT_GT(std::abs(sim.readings.displacement_um(90, 3)), 1e4);
    const SelfCalResult r = SelfCalibrate(sim.readings);
    ASSERT_TRUE(r.rejected.empty());
    ASSERT_TRUE(r.warnings.empty()) << r.warnings.front();
    const auto m = static_cast<std::size_t>(sim.readings.NumPoints());
    EXPECT_EQ(r.readings_used, 4 * (m - 1) - 1);  // the zero at row 40 is none either
    EXPECT_EQ(r.unknowns, 3 * m + 6 + 1);         // the dead path of tracker 4 from row 90
    ASSERT_EQ(r.dead_path_mm.size(), 6u);
    EXPECT_EQ(r.dead_path_zero_row, (std::vector<int>{0, 0, 40, 0, 0, -1}));
    EXPECT_EQ(r.dead_path_from_row, (std::vector<int>{0, 0, 40, 0, 0, 90}));
    const Optimum ref = ReferenceFor(o, sim);
    ASSERT_LT(ref.last_step_mm, 1e-9);
    const Agreement a = Compare(r, ref, o);
    EXPECT_LT(a.volumetric_um, 0.05);
    EXPECT_LT(a.trackers_um, 0.05);
    ASSERT_EQ(ref.dead_paths_mm.size(), 1u);
    EXPECT_NEAR(r.dead_path_mm[5], ref.dead_paths_mm[0], 5e-5);
    // A zero at a point: the tracker's distance to it.
    EXPECT_NEAR(r.dead_path_mm[2], (ref.points_mm[40] - ref.trackers_mm[1]).norm(), 5e-5);
    const test::Accuracy acc = test::Evaluate(o, sim, r);
    EXPECT_LT(acc.volumetric_rms_um, 2.0 * acc.predicted_rms_um);
    EXPECT_LT(acc.tracker_max_sigmas, 4.5);
  }
}

TEST(TrackerEqOne, AReadingThatIsNotZeroWhereTheFileSaysZero) {
  // At a break without `elsewhere` whose reading at its point is not 0 the tracker cannot have
  // been re-zeroed there: taken as elsewhere, with a warning naming tracker, point and the line to
  // write. The same survey marked `elsewhere` gives the same answer without the warning.
  auto o = SurveyOf({"", TrackerMode::kSimultaneous, 400.0, 6, 550.0, 800.0, 341});
  o.beam_breaks = {{2, 70, true}};
  const auto sim = SimulateTrackerSurvey(o);
  const SelfCalResult marked = SelfCalibrate(sim.readings);
  EXPECT_TRUE(marked.warnings.empty());
  auto unmarked = sim.readings;
  unmarked.beam_breaks[0].elsewhere = false;
  const SelfCalResult taken = SelfCalibrate(unmarked);
  ASSERT_EQ(taken.warnings.size(), 1u);
  EXPECT_NE(taken.warnings[0].find("tracker 3 reads"), std::string::npos) << taken.warnings[0];
  EXPECT_NE(taken.warnings[0].find("# beam_break: 3, 71, elsewhere"), std::string::npos)
      << taken.warnings[0];
  EXPECT_EQ(taken.dead_path_zero_row, marked.dead_path_zero_row);
  for (std::size_t i = 0; i < marked.volumetric_error_um.size(); ++i) {
    EXPECT_LT((taken.volumetric_error_um[i] - marked.volumetric_error_um[i]).norm(), 1e-6);
  }
  // A noisy zero at the break's point (0.4 µm, within 10 µm of 0): re-zeroed at the point, the
  // reading not used (said in a warning).
  auto at_point = sim.readings;
  at_point.beam_breaks[0].elsewhere = false;
  at_point.displacement_um(70, 2) = 0.4;
  for (int i = 71; i < at_point.NumPoints(); ++i) {
    at_point.displacement_um(i, 2) =
        sim.readings.displacement_um(i, 2) - sim.readings.displacement_um(70, 2);
  }
  const SelfCalResult noisy = SelfCalibrate(at_point);
  ASSERT_EQ(noisy.warnings.size(), 1u);
  EXPECT_NE(noisy.warnings[0].find("tracker 3 reads 0.4 um at point 71"), std::string::npos)
      << noisy.warnings[0];
  EXPECT_NE(noisy.warnings[0].find("not used"), std::string::npos) << noisy.warnings[0];
  EXPECT_EQ(noisy.dead_path_zero_row, (std::vector<int>{0, 0, 0, 70, 0}));
  at_point.displacement_um(70, 2) = 0.0;
  const SelfCalResult exact = SelfCalibrate(at_point);
  EXPECT_TRUE(exact.warnings.empty());
  for (std::size_t i = 0; i < exact.volumetric_error_um.size(); ++i) {
    EXPECT_LT((noisy.volumetric_error_um[i] - exact.volumetric_error_um[i]).norm(), 1e-6);
  }
  // A reading other than 0 at the first point: eq. (1) does not use it (said in a warning).
  auto first = sim.readings;
  first.displacement_um(0, 1) = 3.5;
  const SelfCalResult f = SelfCalibrate(first);
  ASSERT_EQ(f.warnings.size(), 1u);
  EXPECT_NE(f.warnings[0].find("tracker 2 reads 3.5 um at point 1"), std::string::npos)
      << f.warnings[0];
  for (std::size_t i = 0; i < marked.volumetric_error_um.size(); ++i) {
    EXPECT_LT((f.volumetric_error_um[i] - marked.volumetric_error_um[i]).norm(), 1e-6);
  }
}

TEST(TrackerEqOne, ReadingsNotFromPointOneHaveADeadPath) {
  // Tracker 4's readings 25 mm off from the start (its interferometer zeroed somewhere else than
  // at point 1): its first segment is taken as zeroed elsewhere, with a warning, and the answer
  // is the optimum with that dead path (the reference given a break at row 0 `elsewhere`).
  auto o = SurveyOf({"", TrackerMode::kSimultaneous, 400.0, 6, 550.0, 800.0, 351});
  auto sim = SimulateTrackerSurvey(o);
  for (int i = 0; i < sim.readings.NumPoints(); ++i) sim.readings.displacement_um(i, 3) += 25e3;
  const SelfCalResult r = SelfCalibrate(sim.readings);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("tracker 4 reads 25000 um at point 1"), std::string::npos)
      << r.warnings[0];
  EXPECT_NE(r.warnings[0].find("zeroed elsewhere"), std::string::npos) << r.warnings[0];
  EXPECT_EQ(r.dead_path_zero_row, (std::vector<int>{0, 0, 0, -1}));
  const auto m = static_cast<std::size_t>(sim.readings.NumPoints());
  EXPECT_EQ(r.readings_used, 3 * (m - 1) + m);
  EXPECT_EQ(r.unknowns, 3 * m + 6 + 1);
  auto declared = sim;
  declared.readings.beam_breaks = {{3, 0, true}};
  const Optimum ref = ReferenceFor(o, declared);
  const Agreement a = Compare(r, ref, o);
  EXPECT_LT(a.volumetric_um, 0.05);
  EXPECT_LT(a.trackers_um, 0.05);
  ASSERT_EQ(ref.dead_paths_mm.size(), 1u);
  EXPECT_NEAR(r.dead_path_mm[3], ref.dead_paths_mm[0], 5e-5);
  const test::Accuracy acc = test::Evaluate(o, sim, r);
  EXPECT_LT(acc.volumetric_rms_um, 2.0 * acc.predicted_rms_um);
}

}  // namespace
}  // namespace km::tracker
