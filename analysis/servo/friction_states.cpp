#include "analysis/servo/friction_states.h"

#include <algorithm>
#include <cmath>

namespace km::servo {
namespace {

double Step(double state, double travel, double ramp) {
  if (ramp > 0.0) return std::clamp(state + 2.0 * travel / ramp, -1.0, 1.0);
  return travel > 0.0 ? 1.0 : (travel < 0.0 ? -1.0 : state);
}

}  // namespace

FrictionPath PathOf(const std::vector<MotionSample>& motion) {
  const std::size_t n = motion.size();
  FrictionPath p;
  p.swing_mm.resize(n);
  p.strut_mm.resize(n);
  double travel = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t prev = i == 0 ? n - 1 : i - 1;
    const auto& s = motion[i];
    const auto& q = motion[prev];
    for (int j = 0; j < 6; ++j) {
      const Eigen::Vector3d d =
          (s.frame.lever_mm[j] + s.pose.tip_mm) - (q.frame.lever_mm[j] + q.pose.tip_mm);
      for (int k = 0; k < 2; ++k) p.swing_mm[i][2 * j + k] = s.swing_axis[j][k].dot(d);
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
    p.swing_mm[0].fill(0.0);
    p.strut_mm[0].fill(0.0);
  }
  return p;
}

void FrictionStates(const FrictionPath& path, double joint_ramp_mm, double screw_ramp_mm,
                    std::vector<std::array<double, 12>>& r, std::vector<std::array<double, 6>>& s) {
  const std::size_t n = path.swing_mm.size();
  r.resize(n);
  s.resize(n);
  std::array<double, 12> jr{};
  std::array<double, 6> sr{};
  const auto advance = [&](std::size_t i) {
    for (int q = 0; q < 12; ++q) jr[q] = Step(jr[q], path.swing_mm[i][q], joint_ramp_mm);
    for (int j = 0; j < 6; ++j) sr[j] = Step(sr[j], path.strut_mm[i][j], screw_ramp_mm);
  };
  if (path.closed) {
    for (std::size_t i = 0; i < n; ++i) advance(i);
  } else {
    // Steady sliding before the record, in the direction of each axis's first motion.
    for (int q = 0; q < 12; ++q) {
      for (std::size_t i = 0; i < n && jr[q] == 0.0; ++i)
        jr[q] = Step(0.0, path.swing_mm[i][q], 0.0);
    }
    for (int j = 0; j < 6; ++j) {
      for (std::size_t i = 0; i < n && sr[j] == 0.0; ++i)
        sr[j] = Step(0.0, path.strut_mm[i][j], 0.0);
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    advance(i);
    r[i] = jr;
    s[i] = sr;
  }
}

}  // namespace km::servo
