// Uncertainty of the self-calibration from the stated ranging uncertainty (docs/methods.md §16.5):
// the Monte Carlo through the solver against the linearised covariance u²·(JᵀJ)⁻¹ computed here
// from a Jacobian of [Tracker paper] eq. (1) by central differences (not the solver's), on a
// synthetic survey with known truth; the same seed gives the same numbers; the parser refuses an
// implausible u_ranging_um naming file, line and field.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "analysis/core/errors.h"
#include "analysis/tracker/selfcal_uncertainty.h"
#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_sim.h"
#include "ingest/tracker_parser.h"
#include "tests/unit/tracker/tracker_test_util.h"

namespace km::tracker {
namespace {

// The readings d_ij = |u_i − U_j| − |u_0 − U_j| (i ≥ 1) of the gauge-frame parameters
// p = [x of U_2, x y of U_3, x y z of U_4 … U_n, u_0 … u_{m−1}] (mm), in mm.
struct Eq1 {
  int m = 0, n = 0;
  std::vector<Eigen::Vector3d> U, u;  // gauge frame, the template the parameters fill in

  int TrackerParams() const { return 1 + 2 + 3 * (n - 3); }
  int NumParams() const { return TrackerParams() + 3 * m; }
  void Unpack(const Eigen::VectorXd& p, std::vector<Eigen::Vector3d>& Uo,
              std::vector<Eigen::Vector3d>& uo) const {
    Uo = U;
    uo = u;
    int k = 0;
    Uo[1].x() = p(k++);
    Uo[2].x() = p(k++);
    Uo[2].y() = p(k++);
    for (int j = 3; j < n; ++j) {
      for (int a = 0; a < 3; ++a) Uo[static_cast<std::size_t>(j)](a) = p(k++);
    }
    for (int i = 0; i < m; ++i) {
      for (int a = 0; a < 3; ++a) uo[static_cast<std::size_t>(i)](a) = p(k++);
    }
  }
  Eigen::VectorXd Pack() const {
    Eigen::VectorXd p(NumParams());
    int k = 0;
    p(k++) = U[1].x();
    p(k++) = U[2].x();
    p(k++) = U[2].y();
    for (int j = 3; j < n; ++j) {
      for (int a = 0; a < 3; ++a) p(k++) = U[static_cast<std::size_t>(j)](a);
    }
    for (int i = 0; i < m; ++i) {
      for (int a = 0; a < 3; ++a) p(k++) = u[static_cast<std::size_t>(i)](a);
    }
    return p;
  }
  Eigen::VectorXd Readings(const Eigen::VectorXd& p) const {
    std::vector<Eigen::Vector3d> Uo, uo;
    Unpack(p, Uo, uo);
    Eigen::VectorXd d(n * (m - 1));
    int k = 0;
    for (int j = 0; j < n; ++j) {
      const auto& Uj = Uo[static_cast<std::size_t>(j)];
      for (int i = 1; i < m; ++i)
        d(k++) = (uo[static_cast<std::size_t>(i)] - Uj).norm() - (uo[0] - Uj).norm();
    }
    return d;
  }
};

TEST(TrackerUncertainty, MonteCarloMatchesTheLinearisedCovariance) {
  TrackerSimOptions o = test::MakeSetup(300.0, 3, 4, 11);  // 27 points, 4 trackers
  o.noise_um = 0.05;
  const TrackerSimResult sim = SimulateTrackerSurvey(o);
  SelfCalSolution solution;
  const SelfCalResult r = SelfCalibrate(sim.readings, {}, &solution);
  const double u = 0.5;
  RangingUncertaintyOptions mo;
  mo.draws = 500;
  const RangingUncertainty p = PropagateRangingUncertainty(sim.readings, r, solution, u, mo);

  // The linearised covariance at the truth, in the gauge frame.
  Eq1 eq;
  eq.m = sim.readings.NumPoints();
  eq.n = sim.readings.NumTrackers();
  const RigidTransform g = GaugeTransform(o.trackers_mm);
  for (const auto& t : o.trackers_mm) eq.U.push_back(g.Apply(t));
  for (const auto& t : sim.true_points_mm) eq.u.push_back(g.Apply(t));
  const Eigen::VectorXd p0 = eq.Pack();
  Eigen::MatrixXd J(eq.n * (eq.m - 1), eq.NumParams());
  for (int k = 0; k < eq.NumParams(); ++k) {
    Eigen::VectorXd a = p0, b = p0;
    a(k) += 1e-4;
    b(k) -= 1e-4;
    J.col(k) = (eq.Readings(a) - eq.Readings(b)) / 2e-4;
  }
  const Eigen::MatrixXd C = (u * u) * (J.transpose() * J).inverse();  // µm² per mm²
  // σ of the tracker coordinates (µm) and of |u_0 − U_j| (µm).
  std::vector<double> expect_tracker;
  for (int k = 0; k < eq.TrackerParams(); ++k) expect_tracker.push_back(std::sqrt(C(k, k)));
  int checked = 0;
  for (std::size_t f = 0, t = 0; f < p.figure_keys.size(); ++f) {
    if (p.figure_tracker[f] < 0) continue;
    const double mc = p.mc.outputs[f].u;
    EXPECT_NEAR(mc, expect_tracker[t], 0.10 * expect_tracker[t]) << p.figure_keys[f];
    EXPECT_NEAR(p.u_gum_um[f], expect_tracker[t], 0.02 * expect_tracker[t]) << p.figure_keys[f];
    ++t;
    ++checked;
  }
  EXPECT_EQ(checked, eq.TrackerParams());
  int dead = 0;
  for (std::size_t f = 0; f < p.figure_keys.size(); ++f) {
    if (p.figure_keys[f].rfind("dead_paths[", 0) != 0) continue;
    const int j = dead++;  // one segment per tracker, zeroed at point 1
    Eigen::VectorXd grad = Eigen::VectorXd::Zero(eq.NumParams());
    for (int k = 0; k < eq.NumParams(); ++k) {
      Eigen::VectorXd a = p0, b = p0;
      a(k) += 1e-4;
      b(k) -= 1e-4;
      std::vector<Eigen::Vector3d> Ua, ua, Ub, ub;
      eq.Unpack(a, Ua, ua);
      eq.Unpack(b, Ub, ub);
      grad(k) = ((ua[0] - Ua[static_cast<std::size_t>(j)]).norm() -
                 (ub[0] - Ub[static_cast<std::size_t>(j)]).norm()) /
                2e-4;
    }
    const double expect = std::sqrt(grad.dot(C * grad));
    EXPECT_NEAR(p.mc.outputs[f].u, expect, 0.10 * expect) << p.figure_keys[f];
  }
  EXPECT_EQ(dead, 4);
  EXPECT_EQ(p.figure_keys[0], "volumetric_error_max_um");
  EXPECT_GT(p.mc.outputs[0].u, 0.0);

  // Reproducible: the same seed, the same numbers.
  const RangingUncertainty again = PropagateRangingUncertainty(sim.readings, r, solution, u, mo);
  for (std::size_t k = 0; k < p.mc.outputs.size(); ++k) {
    EXPECT_EQ(p.mc.outputs[k].u, again.mc.outputs[k].u);
  }
}

TEST(TrackerUncertainty, ParserRefusesAnImplausibleRangingUncertainty) {
  const std::string text =
      "# format: kinemetric-tracker/1\n"
      "# machine_id: vmc-1\n"
      "# trackers: 4\n"
      "# u_ranging_um: 2500\n"
      "# mode: simultaneous\n"
      "point,x_mm,y_mm,z_mm,d1_um,d2_um,d3_um,d4_um\n"
      "1,0,0,0,0,0,0,0\n";
  try {
    ingest::ParseTrackerFile(text, "survey.csv");
    FAIL() << "accepted u_ranging_um 2500";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "survey.csv");
    EXPECT_EQ(e.line(), 4u);
    EXPECT_EQ(e.field(), "u_ranging_um");
  }
  const std::string ok =
      text.substr(0, text.find("2500")) + "0.8" + text.substr(text.find("2500") + 4);
  EXPECT_NO_THROW(ingest::ParseTrackerFile(ok, "survey.csv"));
}

}  // namespace
}  // namespace km::tracker
