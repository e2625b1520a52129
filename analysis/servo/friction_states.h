// Friction states along a hexapod record ([Joint patent] figs. 10–12; [PM-600 report]
// eqs. 3.10–3.12). Each ball screw carries a state in [−1, 1] that moves by 2δ/λ with the strut
// travel δ per sample, so its friction goes over to the other side as a linear ramp over the
// travel λ after a reversal (λ = 0: a step). Each base joint carries one friction direction
// state r on the unit disk of the plane normal to its strut (analysis/hexapod/joint_swing.h
// StepSwingState): it moves by 2δ/λ with the joint's swing δ (the platform joint's displacement
// across the strut), so its force −(f_t,j/L_j) r turns with the swing and passes to the other
// side over a swing λ after a reversal; λ = 0 is eq. 3.11 as printed, r = unit(swing). A closed
// path (the last pose next to the first, e.g. a full circle) starts from the steady state of
// its own motion; an open one from steady sliding in the direction of its first motion.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

#include "analysis/servo/hexapod_motion.h"

namespace km::servo {

using JointStates = std::array<Eigen::Vector3d, 6>;  // r_j, one per base joint

struct FrictionPath {
  std::vector<JointStates> swing_mm;            // per joint: swing velocity × time step
  std::vector<JointStates> unit;                // strut directions l_j at each sample
  std::vector<std::array<double, 6>> strut_mm;  // strut length change since the last sample
  bool closed = false;
};

FrictionPath PathOf(const std::vector<MotionSample>& motion);

// States after each sample: joints r[i][j], screws s[i][j].
void FrictionStates(const FrictionPath& path, double joint_ramp_mm, double screw_ramp_mm,
                    std::vector<JointStates>& r, std::vector<std::array<double, 6>>& s);

// The joint states alone (the screws' are not needed by the joint ramp search).
std::vector<JointStates> JointFrictionStates(const FrictionPath& path, double joint_ramp_mm);

// The joint states before the first sample (JointFrictionStates: a closed path after one pass
// of its own motion, an open one in the direction of each joint's first swing), and one step
// of them at sample i — for a search that needs them once, sample by sample.
JointStates InitialJointStates(const FrictionPath& path, double joint_ramp_mm);
void StepJointStates(const FrictionPath& path, std::size_t i, double joint_ramp_mm, JointStates& r);

}  // namespace km::servo
