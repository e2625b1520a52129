// Friction states along a hexapod record ([Joint patent] figs. 10–12; docs/hexapod-effects.md
// § joint_friction): each base-joint swing axis and each ball screw carries a state in [−1, 1]
// that moves by 2δ/λ with its travel δ per sample, so the friction goes over to the other side
// as a linear ramp over the travel λ after a reversal (λ = 0: a step). A closed path (the last
// pose next to the first, e.g. a full circle) starts from the steady state of its own motion;
// an open one from steady sliding in the direction of its first motion.
#pragma once

#include <array>
#include <vector>

#include "analysis/servo/hexapod_motion.h"

namespace km::servo {

struct FrictionPath {
  std::vector<std::array<double, 12>> swing_mm;  // per joint axis (2j + k), since the last sample
  std::vector<std::array<double, 6>> strut_mm;   // strut length change since the last sample
  bool closed = false;
};

FrictionPath PathOf(const std::vector<MotionSample>& motion);

// States after each sample: joints r[i][2j + k], screws s[i][j].
void FrictionStates(const FrictionPath& path, double joint_ramp_mm, double screw_ramp_mm,
                    std::vector<std::array<double, 12>>& r, std::vector<std::array<double, 6>>& s);

}  // namespace km::servo
