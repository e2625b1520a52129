// Hexapod kinematics ([PM-600 report] §1.4): rotation convention, IK/FK round trip over the
// workspace, analytic Jacobian vs numerical differentiation, singularity handling, strut-offset
// convention.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/SVD>

#include "analysis/core/angles.h"
#include "analysis/core/errors.h"
#include "analysis/hexapod/kinematics.h"
#include "tests/unit/hexapod/pm600_fixture.h"

namespace km::hexapod {
namespace {

Pose RandomWorkspacePose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Pose p;
  double x, y;
  do {
    x = u(rng);
    y = u(rng);
  } while (x * x + y * y > 1.0);
  const double zmid = 0.5 * (test::kWorkspaceZLowMm + test::kWorkspaceZHighMm);
  const double zhalf = 0.5 * (test::kWorkspaceZHighMm - test::kWorkspaceZLowMm);
  p.tip_mm = {test::kWorkspaceRadiusMm * x, test::kWorkspaceRadiusMm * y, zmid + zhalf * u(rng)};
  double a, b;
  do {
    a = u(rng);
    b = u(rng);
  } while (a * a + b * b > 1.0);
  p.abc_rad =
      Eigen::Vector3d(a * test::kMaxTiltDeg, b * test::kMaxTiltDeg, u(rng) * test::kMaxSpinDeg) *
      kDeg;
  return p;
}

TEST(HexapodKinematics, RotationMatchesSeedEquation14) {
  // Independent: the explicit matrix of [PM-600 report] eq. 1.4.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 20; ++i) {
    const double A = u(rng), B = u(rng), C = u(rng);
    Eigen::Matrix3d ref;
    ref << std::cos(B) * std::cos(C), -std::cos(B) * std::sin(C), std::sin(B),
        std::cos(A) * std::sin(C) + std::sin(A) * std::sin(B) * std::cos(C),
        std::cos(A) * std::cos(C) - std::sin(A) * std::sin(B) * std::sin(C),
        -std::sin(A) * std::cos(B),
        std::sin(A) * std::sin(C) - std::cos(A) * std::sin(B) * std::cos(C),
        std::sin(A) * std::cos(C) + std::cos(A) * std::sin(B) * std::sin(C),
        std::cos(A) * std::cos(B);
    EXPECT_LT((RotationABC(Eigen::Vector3d(A, B, C)) - ref).norm(), 1e-14);
  }
}

TEST(HexapodKinematics, InverseKinematicsMatchesDirectGeometry) {
  // Independent computation: tool tip at (0,0,-l) in the platform frame, so the spindle nose is
  // at X + R·(0,0,l) and the platform joint at nose + R·p_j.
  const auto g = test::Pm600Like();
  std::mt19937 rng(5);
  for (int i = 0; i < 50; ++i) {
    const Pose p = RandomWorkspacePose(rng);
    const double l = 100.0 + i;
    const Eigen::Matrix3d R = RotationABC(p.abc_rad);
    const Eigen::Vector3d nose = p.tip_mm + R * Eigen::Vector3d(0, 0, l);
    const auto s = InverseKinematics(g, p, l);
    for (int j = 0; j < 6; ++j) {
      const double d = (nose + R * g.platform_joints_mm[j] - g.base_joints_mm[j]).norm();
      EXPECT_NEAR(s[j], d, 1e-10);
    }
  }
}

// Condition number computed here, independently of PoseJacobian: J = ds/dT by central
// differences of the inverse kinematics, the angle columns divided by the mean platform-joint
// radius in the xy-plane (the characteristic length of kinematics.h), 2-norm condition by SVD.
double NumericalScaledCondition(const HexapodGeometry& g, const Pose& pose, double tool) {
  double radius = 0.0;
  for (const auto& p : g.platform_joints_mm) radius += std::hypot(p.x(), p.y());
  radius /= 6.0;
  Eigen::Matrix<double, 6, 6> J;
  for (int c = 0; c < 6; ++c) {
    const double h = c < 3 ? 1e-4 : 1e-7;  // mm, rad
    Pose plus = pose, minus = pose;
    (c < 3 ? plus.tip_mm[c] : plus.abc_rad[c - 3]) += h;
    (c < 3 ? minus.tip_mm[c] : minus.abc_rad[c - 3]) -= h;
    J.col(c) = (InverseKinematics(g, plus, tool) - InverseKinematics(g, minus, tool)) / (2.0 * h);
    if (c >= 3) J.col(c) /= radius;
  }
  const Eigen::JacobiSVD<Eigen::Matrix<double, 6, 6>> svd(J);
  return svd.singularValues()[0] / svd.singularValues()[5];
}

TEST(HexapodKinematics, ForwardRoundTripsInverseOverWorkspace) {
  const auto g0 = test::Pm600Like();
  for (unsigned seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    auto g = g0;
    for (auto& o : g.strut_offset_mm) o = 0.1 * u(rng);
    double worst_mm = 0.0, worst_rad = 0.0;
    for (int i = 0; i < 500; ++i) {
      const Pose truth = RandomWorkspacePose(rng);
      const double tool = 100.0 + 50.0 * u(rng);
      const auto s = InverseKinematics(g, truth, tool);
      Pose guess = truth;  // start a few mm / degrees away
      guess.tip_mm += Eigen::Vector3d(u(rng), u(rng), u(rng)) * 5.0;
      guess.abc_rad += Eigen::Vector3d(u(rng), u(rng), u(rng)) * 2.0 * kDeg;
      ForwardOptions opt;
      opt.report_condition_number = true;
      const auto fk = ForwardKinematics(g, s, tool, guess, opt);
      worst_mm = std::max(worst_mm, (fk.pose.tip_mm - truth.tip_mm).cwiseAbs().maxCoeff());
      worst_rad = std::max(worst_rad, (fk.pose.abc_rad - truth.abc_rad).cwiseAbs().maxCoeff());
      EXPECT_LE(fk.max_strut_residual_mm, 1e-10);
      EXPECT_NEAR(fk.condition_number, NumericalScaledCondition(g, truth, tool),
                  1e-5 * fk.condition_number);
      EXPECT_LT(fk.condition_number, 1e3);  // the workspace is far from singular
      EXPECT_LE(fk.iterations, 10);
    }
    std::printf("seed %u: worst FK-IK round trip %.2e mm, %.2e rad over 500 poses\n", seed,
                worst_mm, worst_rad);
    EXPECT_LT(worst_mm, 1e-9) << "seed " << seed;
    EXPECT_LT(worst_rad, 1e-11) << "seed " << seed;
  }
}

TEST(HexapodKinematics, AnalyticJacobianMatchesNumericalDifferentiation) {
  const auto g = test::Pm600Like();
  std::mt19937 rng(7);
  for (int i = 0; i < 20; ++i) {
    const Pose p = RandomWorkspacePose(rng);
    const Matrix6d J = PoseJacobian(g, p, 120.0);
    const Vector6d v = p.AsVector();
    for (int c = 0; c < 6; ++c) {
      const double h = c < 3 ? 1e-4 : 1e-7;
      Vector6d vp = v, vm = v;
      vp[c] += h;
      vm[c] -= h;
      const Vector6d num = (InverseKinematics(g, Pose::FromVector(vp), 120.0) -
                            InverseKinematics(g, Pose::FromVector(vm), 120.0)) /
                           (2 * h);
      const double scale = c < 3 ? 1.0 : CharacteristicLengthMm(g);
      EXPECT_LT((J.col(c) - num).cwiseAbs().maxCoeff(), 1e-6 * scale) << "column " << c;
    }
  }
}

TEST(HexapodKinematics, StrutOffsetConventionTrueMinusCommanded) {
  // A machine whose strut j is o_j longer than the nominal model thinks realises, for the
  // nominal command s, the joint distance s + o_j.
  const auto nominal = test::Pm600Like();
  auto real = nominal;
  real.strut_offset_mm = {0.05, -0.02, 0.0, 0.01, 0.0, -0.07};
  Pose cmd;
  cmd.tip_mm = {50, -30, -950};
  const double l = 100.0;
  const auto s = InverseKinematics(nominal, cmd, l);
  const auto fk = ForwardKinematics(real, s, l, cmd);
  const auto P = PlatformJointsInMachine(real, fk.pose, l);
  for (int j = 0; j < 6; ++j) {
    EXPECT_NEAR((P[j] - real.base_joints_mm[j]).norm(), s[j] + real.strut_offset_mm[j], 1e-10);
  }
  EXPECT_GT((fk.pose.tip_mm - cmd.tip_mm).norm(), 1e-3);  // the pose error is real
}

TEST(HexapodKinematics, NearSingularPoseIsRefused) {
  // Platform joints in the base-joint plane: all struts horizontal, ∂s/∂Z = 0 (singular).
  const auto g = test::Pm600Like();
  const double l = 100.0;
  Pose singular;
  singular.tip_mm = {0, 0, -(250.0 + l)};
  EXPECT_GT(JacobianConditionNumber(g, singular, l), 1e8);
  const auto s = InverseKinematics(g, singular, l);
  Pose guess = singular;
  guess.tip_mm.z() -= 2.0;
  EXPECT_THROW(ForwardKinematics(g, s, l, guess), DidNotConverge);
  // 1 µm above the singular plane: still refused (the mirror pose is indistinguishable).
  Pose near = singular;
  near.tip_mm.z() += 1e-3;
  EXPECT_THROW(ForwardKinematics(g, InverseKinematics(g, near, l), l, near), DidNotConverge);
  // Unreachable strut lengths do not produce a pose either.
  Vector6d bad = s;
  bad[0] += 2000.0;
  EXPECT_THROW(ForwardKinematics(g, bad, l, guess), DidNotConverge);
}

}  // namespace
}  // namespace km::hexapod
