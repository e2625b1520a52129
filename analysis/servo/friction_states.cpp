#include "analysis/servo/friction_states.h"

#include <algorithm>
#include <cmath>

#include "analysis/hexapod/joint_swing.h"

namespace km::servo {
namespace {

double Step(double state, double travel, double ramp) {
  if (ramp > 0.0) return std::clamp(state + 2.0 * travel / ramp, -1.0, 1.0);
  return travel > 0.0 ? 1.0 : (travel < 0.0 ? -1.0 : state);
}

// Steady sliding before an open record: each joint's state is the direction of its first swing.
JointStates FirstSwing(const FrictionPath& path) {
  JointStates r;
  r.fill(Eigen::Vector3d::Zero());
  for (int j = 0; j < 6; ++j) {
    for (std::size_t i = 0; i < path.swing_mm.size() && r[j].isZero(); ++i) {
      r[j] = hexapod::StepSwingState(r[j], path.unit[i][j], path.swing_mm[i][j], 0.0);
    }
  }
  return r;
}

}  // namespace

void StepJointStates(const FrictionPath& path, std::size_t i, double joint_ramp_mm,
                     JointStates& r) {
  for (int j = 0; j < 6; ++j) {
    r[j] = hexapod::StepSwingState(r[j], path.unit[i][j], path.swing_mm[i][j], joint_ramp_mm);
  }
}

JointStates InitialJointStates(const FrictionPath& path, double joint_ramp_mm) {
  if (!path.closed) return FirstSwing(path);
  JointStates jr;
  jr.fill(Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < path.swing_mm.size(); ++i)
    StepJointStates(path, i, joint_ramp_mm, jr);
  return jr;
}

FrictionPath PathOf(const std::vector<MotionSample>& motion) {
  const std::size_t n = motion.size();
  FrictionPath p;
  p.swing_mm.resize(n);
  p.unit.resize(n);
  p.strut_mm.resize(n);
  double travel = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t prev = i == 0 ? n - 1 : i - 1;
    const auto& s = motion[i];
    const auto& q = motion[prev];
    for (int j = 0; j < 6; ++j) {
      // The swing over the sample, centred on it (its swing velocity × its time step), so that
      // with λ → 0 the state is unit(L_j dl_j/dt) at the sample, the direction of eq. 3.11.
      p.unit[i][j] = s.frame.unit[j];
      p.swing_mm[i][j] = s.swing_mm_s[j] * s.dt_s;
      p.strut_mm[i][j] = s.frame.length_mm[j] - q.frame.length_mm[j];
    }
    if (i > 0) travel += (s.pose.tip_mm - q.pose.tip_mm).norm();
  }
  // Closed: the step from the last sample back to the first is no longer than the mean step.
  if (n > 2) {
    const double closing = (motion.front().pose.tip_mm - motion.back().pose.tip_mm).norm() +
                           (motion.front().pose.abc_rad - motion.back().pose.abc_rad).norm() * 1e3;
    p.closed = closing <= 2.0 * travel / static_cast<double>(n - 1);
  }
  if (!p.closed && n > 0) {  // no step into the first sample
    p.swing_mm[0].fill(Eigen::Vector3d::Zero());
    p.strut_mm[0].fill(0.0);
  }
  return p;
}

std::vector<JointStates> JointFrictionStates(const FrictionPath& path, double joint_ramp_mm) {
  const std::size_t n = path.swing_mm.size();
  std::vector<JointStates> r(n);
  if (!path.closed) {
    JointStates jr = InitialJointStates(path, joint_ramp_mm);
    for (std::size_t i = 0; i < n; ++i) {
      StepJointStates(path, i, joint_ramp_mm, jr);
      r[i] = jr;
    }
    return r;
  }
  // A closed path: one pass from rest (InitialJointStates) kept, then the pass from its last
  // states. A joint whose state meets the first pass's at a sample (to the last bit) follows it
  // from there on — the same steps from the same state — and is not stepped again.
  JointStates jr;
  jr.fill(Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < n; ++i) {
    StepJointStates(path, i, joint_ramp_mm, jr);
    r[i] = jr;
  }
  for (int j = 0; j < 6; ++j) {
    Eigen::Vector3d state = jr[j];
    for (std::size_t i = 0; i < n; ++i) {
      state = hexapod::StepSwingState(state, path.unit[i][j], path.swing_mm[i][j], joint_ramp_mm);
      if (state == r[i][j]) break;
      r[i][j] = state;
    }
  }
  return r;
}

void FrictionStates(const FrictionPath& path, double joint_ramp_mm, double screw_ramp_mm,
                    std::vector<JointStates>& r, std::vector<std::array<double, 6>>& s) {
  const std::size_t n = path.strut_mm.size();
  r = JointFrictionStates(path, joint_ramp_mm);
  s.resize(n);
  std::array<double, 6> sr{};
  if (path.closed) {
    for (std::size_t i = 0; i < n; ++i) {
      for (int j = 0; j < 6; ++j) sr[j] = Step(sr[j], path.strut_mm[i][j], screw_ramp_mm);
    }
  } else {
    // Steady sliding before the record, in the direction of each strut's first motion.
    for (int j = 0; j < 6; ++j) {
      for (std::size_t i = 0; i < n && sr[j] == 0.0; ++i)
        sr[j] = Step(0.0, path.strut_mm[i][j], 0.0);
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (int j = 0; j < 6; ++j) sr[j] = Step(sr[j], path.strut_mm[i][j], screw_ramp_mm);
    s[i] = sr;
  }
}

}  // namespace km::servo
