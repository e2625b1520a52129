// The reference hexapod of data/machines/pm600-like.json, embedded so the tests do
// not depend on files outside the repository (io_test checks the JSON round trip separately).
#pragma once

#include "analysis/hexapod/kinematics.h"

namespace km::hexapod::test {

inline HexapodGeometry Pm600Like() {
  HexapodGeometry g;
  g.base_joints_mm = {
      Eigen::Vector3d(128.905, 606.452, 0.0),   Eigen::Vector3d(-128.905, 606.452, 0.0),
      Eigen::Vector3d(-589.655, -191.591, 0.0), Eigen::Vector3d(-460.75, -414.861, 0.0),
      Eigen::Vector3d(460.75, -414.861, 0.0),   Eigen::Vector3d(589.655, -191.591, 0.0)};
  g.platform_joints_mm = {
      Eigen::Vector3d(133.826, 148.629, 250.0), Eigen::Vector3d(-133.826, 148.629, 250.0),
      Eigen::Vector3d(-195.63, 41.582, 250.0),  Eigen::Vector3d(-61.803, -190.211, 250.0),
      Eigen::Vector3d(61.803, -190.211, 250.0), Eigen::Vector3d(195.63, 41.582, 250.0)};
  g.strut_offset_mm = {0, 0, 0, 0, 0, 0};
  return g;
}

// Workspace of the tests: tool tip within a 600 mm diameter × 400 mm cylinder, spindle tilt
// (A, B) up to 25° in any direction, C within ±10°, tool length 50–150 mm. (With longer tools
// and the tip high up, the platform approaches the base plane, where the machine is singular.)
inline constexpr double kWorkspaceRadiusMm = 300.0;
inline constexpr double kWorkspaceZLowMm = -1250.0;
inline constexpr double kWorkspaceZHighMm = -850.0;
inline constexpr double kMaxTiltDeg = 25.0;
inline constexpr double kMaxSpinDeg = 10.0;

}  // namespace km::hexapod::test
