// The motion of a hexapod along a servo-load record (docs/methods.md §12): at every sample the
// strut frame of the commanded pose ([PM-600 report] eq. 3.4), and from finite differences in
// time the strut rates dL_j/dt, the swing of each platform joint — its velocity across its
// strut, L_j dl_j/dt, whose direction the base-joint friction of eqs. 3.11–3.12 opposes
// (analysis/hexapod/joint_swing.h) —, the strut and platform angular velocities, and the
// tool-tip acceleration (the inertia of eq. 3.13).
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

#include "analysis/hexapod/statics.h"
#include "analysis/servo/servo_types.h"

namespace km::servo {

struct MotionSample {
  hexapod::Pose pose;
  hexapod::StrutFrame frame;
  double dt_s = 0.0;  // time since the previous sample (the first: to the next)
  Eigen::Vector3d accel_mm_s2 = Eigen::Vector3d::Zero();  // tool tip
  double tip_speed_mm_s = 0.0;
  std::array<double, 6> strut_rate_mm_s{};  // dL_j/dt
  // The swing velocity of each platform joint, L_j dl_j/dt (mm/s): its velocity normal to the
  // strut (SwingOf of joint_swing.h).
  std::array<Eigen::Vector3d, 6> swing_mm_s;
  // Angular velocity of each strut (perpendicular to it) and of the platform, rad/s.
  std::array<Eigen::Vector3d, 6> strut_omega;
  Eigen::Vector3d platform_omega = Eigen::Vector3d::Zero();
};

// Central differences on the (possibly uneven) time grid; one-sided at the ends.
std::vector<MotionSample> TrackMotion(const hexapod::HexapodGeometry& g,
                                      const std::vector<HexapodSample>& samples,
                                      double tool_length_mm);

// Which rows a friction model can use. Friction changes side at a reversal and ramps over a
// short travel after it ([Joint patent] figs. 10–12), so a strut's row is used when the strut
// moves (|dL/dt| >= min_rate_fraction × its median |dL/dt| over the record) and has travelled
// `reversal_skip_mm` since its last reversal. A base joint's friction direction is known when
// its swing speed |L_j dl_j/dt| is >= min_rate_fraction × its median, and settled when over the
// last `reversal_skip_mm` of swing its direction has not turned by more than 90° from the
// present one (a reversal of the swing). A sample's rows are used only when, in addition,
// every joint's friction is settled (the joint friction of all six struts reaches every strut
// through the statics) and the tool tip moves (speed >= min_rate_fraction × its median).
struct RowUse {
  std::array<bool, 6> screw{};  // the strut's direction is known and settled
  bool joints = false;          // every joint's friction direction is known and settled
  bool Row(int j) const { return joints && screw[static_cast<std::size_t>(j)]; }
};
std::vector<RowUse> UsableRows(const std::vector<MotionSample>& motion, double min_rate_fraction,
                               double reversal_skip_mm);

}  // namespace km::servo
