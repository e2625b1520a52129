// The base-joint friction law of the servo-load model from first principles, no simulator:
// [PM-600 report] eq. 3.11 read as one force of size f_t,j/L_j at the platform joint, normal to
// the strut, against the joint's swing L_j dl_j/dt (analysis/hexapod/joint_swing.h). On a
// circle the swing turns continuously; the force must follow it and keep its size (the former
// law on two fixed swing axes gave a square wave of up to √2 × that size).
#include <algorithm>
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "analysis/hexapod/joint_swing.h"
#include "analysis/servo/friction_states.h"
#include "analysis/servo/hexapod_motion.h"
#include "analysis/servo/load_model.h"
#include "tests/unit/servo/servo_fixture.h"

namespace km::servo {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kSpeed = 1000.0 / 60.0;  // mm/s
constexpr double kRadius = 150.0;

// A circle of the tool tip at a constant tilt, `n` samples, CCW, and its analytic velocity.
std::vector<HexapodSample> Circle(int n, const Eigen::Vector3d& tilt_deg) {
  std::vector<HexapodSample> out(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double th = 2.0 * kPi * i / n;
    auto& s = out[static_cast<std::size_t>(i)];
    s.t_s = kRadius * th / kSpeed;
    s.tip_mm = {kRadius * std::cos(th), kRadius * std::sin(th), -1100.0};
    s.abc_deg = {tilt_deg.x(), tilt_deg.y(), tilt_deg.z()};
  }
  return out;
}

Eigen::Vector3d TipVelocity(int i, int n) {
  const double th = 2.0 * kPi * i / n;
  return kSpeed * Eigen::Vector3d(-std::sin(th), std::cos(th), 0.0);
}

TEST(ServoJointLaw, TheFrictionOfEachJointOpposesItsSwingWithTheSizeTorqueOverLength) {
  const int n = 360;
  const double tool = 150.0, t0 = 10.2, t1 = 0.0121, gravity_N = 900.0;
  const auto motion = TrackMotion(test::Pm600Geometry(), Circle(n, {0.0, 15.0, 0.0}), tool);
  const double torque = hexapod::JointFrictionTorque(t0, t1, gravity_N);
  ASSERT_DOUBLE_EQ(torque, t0 + t1 * gravity_N);
  int checked = 0;
  for (int i = 1; i + 1 < n; ++i) {
    const MotionSample& s = motion[static_cast<std::size_t>(i)];
    for (int j = 0; j < 6; ++j) {
      const Eigen::Vector3d& l = s.frame.unit[j];
      // The swing: the platform joint's velocity across the strut (the platform does not turn,
      // so every joint moves with the tool tip), here against the analytic velocity.
      const Eigen::Vector3d v = TipVelocity(i, n);
      const Eigen::Vector3d swing = v - v.dot(l) * l;
      EXPECT_LT((s.swing_mm_s[j] - swing).norm(), 1e-3 * kSpeed) << "sample " << i;
      if (swing.norm() < 0.05 * kSpeed) continue;  // direction ill-defined near a reversal
      const hexapod::Vector6d w = torque * JointFrictionWrench(s, j);
      const Eigen::Vector3d force = w.head<3>();
      const double length_m = s.frame.length_mm[j] / 1e3;
      EXPECT_LT(force.dot(swing), 0.0) << "joint " << j + 1 << ", sample " << i;
      EXPECT_NEAR(force.norm(), torque / length_m, 1e-9 * torque / length_m);
      EXPECT_NEAR(force.dot(swing.normalized()), -torque / length_m, 1e-5 * torque / length_m);
      EXPECT_NEAR(force.dot(l), 0.0, 1e-9 * force.norm());  // normal to the strut
      EXPECT_LT((w.tail<3>() - s.frame.lever_mm[j].cross(force)).norm(), 1e-9 * force.norm());
      ++checked;
    }
  }
  EXPECT_GT(checked, 6 * (n - 2) * 3 / 4);
}

TEST(ServoJointLaw, TheRegressorAddsOneForcePerJointAndTheStateMapIsLinear) {
  const int n = 180;
  const auto motion = TrackMotion(test::Pm600Geometry(), Circle(n, Eigen::Vector3d::Zero()), 0.0);
  const MotionSample& s = motion[37];
  hexapod::Vector6d sum = hexapod::Vector6d::Zero();
  for (int j = 0; j < 6; ++j) {
    const Eigen::Vector3d dir = s.swing_mm_s[j].normalized();
    const hexapod::Vector6d w = JointFrictionWrench(s, j);
    EXPECT_LT((JointFrictionWrenchMap(s, j) * dir - w).norm(), 1e-12 * w.norm());
    sum += w;
  }
  // The t0 column of the strut forces is Γ⁻¹ of the summed wrench of 1 N·m in every joint.
  RowUse use;
  use.joints = true;
  LoadRows a;
  hexapod::Vector6d c;
  hexapod::Vector6d gravity = hexapod::Vector6d::Constant(1000.0);
  gravity[4] = -1000.0;  // a pushed strut loads its joint as a pulled one does
  const JointLoads loads = JointLoadsOf(gravity, 10.2, 0.0121);
  LoadRegressor(test::Pm600Physics(), s, 0.0, loads, use, a, c);
  EXPECT_LT((s.frame.gamma * a.col(kT0) - sum).norm(), 1e-9 * sum.norm());
  EXPECT_TRUE(loads.active[4]);
  EXPECT_DOUBLE_EQ(loads.gravity_N[4], 1000.0);
  EXPECT_LT((a.col(kT1) - 1000.0 * a.col(kT0)).norm(), 1e-9 * a.col(kT1).norm());
  // A negative t1 large enough takes the torque of the loaded joints to nothing.
  const JointLoads none = JointLoadsOf(gravity, 10.2, -0.0121);
  for (int j = 0; j < 6; ++j) EXPECT_FALSE(none.active[j]);
}

// Straight strokes out and back along x: each joint's swing reverses at the turn. The friction
// state with a ramp λ passes linearly to the other side over a swing λ; without one it is
// unit(swing) at once; the rows within `reversal_skip_mm` of swing after the turn are not used.
TEST(ServoJointLaw, AReversalOfTheSwingRampsTheStateAndSkipsTheRows) {
  std::vector<HexapodSample> samples;
  const int half = 200;
  const double step = 0.05;                     // mm a sample
  for (int i = 0; i <= half + half / 2; ++i) {  // out, and half way back
    HexapodSample s;
    s.t_s = 0.01 * i;
    const double x = step * (i <= half ? i : 2 * half - i);
    s.tip_mm = {x, 0.0, -1100.0};
    samples.push_back(s);
  }
  const auto motion = TrackMotion(test::Pm600Geometry(), samples, 0.0);
  const FrictionPath path = PathOf(motion);
  ASSERT_FALSE(path.closed);
  const double ramp = 1.0;
  const auto r = JointFrictionStates(path, ramp);
  const auto r0 = JointFrictionStates(path, 0.0);
  for (int j = 0; j < 6; ++j) {
    const Eigen::Vector3d out = motion[half / 2].swing_mm_s[j].normalized();
    EXPECT_NEAR(r[half / 2][j].dot(out), 1.0, 1e-3) << "joint " << j + 1;
    EXPECT_NEAR(r0[half + 1][j].dot(out), -1.0, 1e-3) << "joint " << j + 1;  // no ramp: at once
    // After the turn the state passes linearly through 0 at a swing of λ/2 to −out at λ.
    double swung = 0.0;
    for (int i = half + 1; i <= half + half / 2 && swung < 1.5 * ramp; ++i) {
      swung += path.swing_mm[i][j].norm();
      const double expected = std::max(-1.0, 1.0 - 2.0 * swung / ramp);
      EXPECT_NEAR(r[i][j].dot(out), expected, 0.01) << "joint " << j + 1 << ", sample " << i;
    }
    EXPECT_GE(swung, 1.5 * ramp);
  }
  const auto use = UsableRows(motion, 0.2, 1.0);
  EXPECT_TRUE(use[half - 5].joints);
  EXPECT_FALSE(use[half + 1].joints);
  EXPECT_FALSE(use[half + 5].joints);
  EXPECT_TRUE(use[half + 80].joints);  // 4 mm of tip travel after the turn
}

}  // namespace
}  // namespace km::servo
