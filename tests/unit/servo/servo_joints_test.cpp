// Recover-the-truth tests of the joint resistance and health levels
// (analysis/servo/joint_resistance.h) on the independent simulator (servo_truth.h): CW and CCW
// circles of the jig plan, noise 2 N, the base-joint friction of [PM-600 report] eq. 3.11 (one
// force f_t/L across the strut against the swing).
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "analysis/servo/joint_resistance.h"
#include "tests/unit/servo/servo_fixture.h"

namespace km::servo {
namespace {

// The simulated resistance of leg j averaged over the poses: t0 + t1·mean ĝ_j per the
// reference of the estimate, so the ratio to it is the simulated factor.
TEST(ServoJoints, NamesTheStiffLegAtLevel3) {
  truth::Machine m = truth::Pm600Truth();
  m.leg_factor[2] = 3.0;
  const auto files = test::SimulatePlan(m, 2.0, 720, 21);
  const JointsResult r =
      EstimateJointResistance(test::Pm600Geometry(), test::Pm600Physics(), files);
  EXPECT_EQ(r.reference_source, "machine model");
  EXPECT_EQ(r.pairs.size(), 15u);
  EXPECT_EQ(r.level, 3);
  for (int j = 0; j < 6; ++j) {
    const auto& leg = r.legs[j];
    EXPECT_NEAR(leg.ratio, m.leg_factor[j], 0.1 * m.leg_factor[j]) << leg.evidence;
    EXPECT_EQ(leg.level, j == 2 ? 3 : 1) << leg.evidence;
    EXPECT_NEAR(leg.screw_friction_N, m.f0[j], 5.0) << leg.evidence;
    // No platform-joint resistance was simulated.
    EXPECT_LT(std::abs(leg.joints[1].resistance_Nm), 0.1 * leg.resistance_Nm) << leg.evidence;
  }
  EXPECT_NE(r.legs[2].evidence.find("leg 3"), std::string::npos);
  EXPECT_LT(r.residual_rms_N, 2.0 * std::sqrt(2.0) * 1.5);
}

TEST(ServoJoints, PairsPosesBetweenSamples) {
  // The CCW circles sampled half a step away from the CW samples (1.3 mm apart on the circle):
  // the CCW loads are interpolated to the CW poses.
  truth::Machine m = truth::Pm600Truth();
  m.leg_factor[5] = 3.0;
  std::mt19937 rng(25);
  std::vector<ServoFile> files;
  for (auto c : truth::JigPlan(720)) {
    for (bool ccw : {true, false}) {
      c.ccw = ccw;
      c.phase_steps = ccw ? 0.5 : 0.0;
      files.push_back(ingest::ParseServoFile(truth::ServoText(c, truth::Simulate(m, c, 2.0, rng)),
                                             c.test_id + ".txt"));
    }
  }
  const JointsResult r =
      EstimateJointResistance(test::Pm600Geometry(), test::Pm600Physics(), files);
  EXPECT_GT(r.rows, 20000u);
  for (int j = 0; j < 6; ++j) {
    EXPECT_NEAR(r.legs[j].ratio, m.leg_factor[j], 0.1 * m.leg_factor[j]) << r.legs[j].evidence;
    EXPECT_EQ(r.legs[j].level, j == 5 ? 3 : 1) << r.legs[j].evidence;
  }
}

TEST(ServoJoints, EqualLegsStayAtLevel1) {
  const truth::Machine m = truth::Pm600Truth();
  const auto files = test::SimulatePlan(m, 2.0, 720, 22);
  const JointsResult r =
      EstimateJointResistance(test::Pm600Geometry(), test::Pm600Physics(), files);
  EXPECT_EQ(r.level, 1);
  for (const auto& leg : r.legs) {
    EXPECT_EQ(leg.level, 1) << leg.evidence;
    EXPECT_NEAR(leg.ratio, 1.0, 0.1) << leg.evidence;
  }
}

TEST(ServoJoints, SeparatesAPlatformJointAndGradesTheGrowth) {
  truth::Machine m = truth::Pm600Truth();
  m.platform_factor[4] = 0.5;  // the platform joint of leg 5 at half the base joint's
  const auto files = test::SimulatePlan(m, 2.0, 720, 23);
  JointOptions o;
  // The previous estimate: every leg as simulated, without the platform joint's resistance.
  const JointsResult before =
      EstimateJointResistance(test::Pm600Geometry(), test::Pm600Physics(),
                              test::SimulatePlan(truth::Pm600Truth(), 2.0, 720, 24));
  std::array<double, 6> prev{};
  for (int j = 0; j < 6; ++j) prev[j] = before.legs[j].resistance_Nm;
  o.previous_Nm = prev;
  const JointsResult r =
      EstimateJointResistance(test::Pm600Geometry(), test::Pm600Physics(), files, o);
  const auto& leg5 = r.legs[4];
  ASSERT_TRUE(leg5.joints[1].identified);
  EXPECT_NEAR(leg5.joints[1].resistance_Nm, 0.5 * prev[4], 0.05 * prev[4]) << leg5.evidence;
  EXPECT_NEAR(leg5.joints[0].resistance_Nm, before.legs[4].resistance_Nm, 0.1 * prev[4])
      << leg5.evidence;
  // About +50 %: above the 30 % warning, below the 100 % stop; the others did not grow.
  EXPECT_EQ(leg5.level, 2) << leg5.evidence;
  for (int j = 0; j < 6; ++j) {
    if (j != 4) {
      EXPECT_EQ(r.legs[j].level, 1) << r.legs[j].evidence;
    }
  }
}

}  // namespace
}  // namespace km::servo
