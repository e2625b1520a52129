#include "analysis/hexapod/statics.h"

#include <Eigen/Geometry>
#include <Eigen/LU>

namespace km::hexapod {

StrutFrame StrutFrameAt(const HexapodGeometry& g, const Pose& pose, double tool_length_mm) {
  const auto p = PlatformJointsInMachine(g, pose, tool_length_mm);
  StrutFrame f;
  for (int j = 0; j < 6; ++j) {
    const Eigen::Vector3d v = p[j] - g.base_joints_mm[j];
    f.length_mm[j] = v.norm();
    f.unit[j] = v / f.length_mm[j];
    f.lever_mm[j] = p[j] - pose.tip_mm;
    f.gamma.block<3, 1>(0, j) = f.unit[j];
    f.gamma.block<3, 1>(3, j) = f.lever_mm[j].cross(f.unit[j]);
  }
  return f;
}

Vector6d TensionsForWrench(const StrutFrame& f, const Eigen::Vector3d& force_N,
                           const Eigen::Vector3d& moment_Nmm) {
  Vector6d rhs;
  rhs << force_N, moment_Nmm;
  return f.gamma.partialPivLu().solve(rhs);
}

Vector6d GravityAxialForces(const MachinePhysics& m, const StrutFrame& f, const Pose& pose,
                            double tool_length_mm) {
  const Eigen::Vector3d& g = m.g_m_s2;
  const Eigen::Vector3d weight = m.platform_mass_kg * g;
  const Eigen::Vector3d cog =
      RotationABC(pose.abc_rad) * (m.platform_cog_mm + Eigen::Vector3d(0.0, 0.0, tool_length_mm));
  Eigen::Vector3d force = weight;
  Eigen::Vector3d moment = cog.cross(weight);
  for (int j = 0; j < 6; ++j) {
    const double len = f.length_mm[j];
    // Part of the strut's weight carried at the platform joint, perpendicular to the strut
    // (eq. 3.7): moments of the strut's masses about the base joint over its length.
    const double w =
        (m.ball_screw_mass_kg * (len - m.platform_joint_length_mm - 0.5 * m.ball_screw_length_mm) +
         m.joint_mass_kg * len - m.motor_mass_kg * m.motor_offset_mm) /
        len;
    const Eigen::Vector3d wg = w * g;
    const Eigen::Vector3d n = wg - wg.dot(f.unit[j]) * f.unit[j];
    force += n;
    moment += f.lever_mm[j].cross(n);
  }
  Vector6d x = TensionsForWrench(f, force, moment);
  // Axial share of the strut's equivalent mass, g_s,j = m_T g·l_j (eq. 3.8), combined with the
  // platform's share as eq. 3.5 does: Γ(ĝ − g_s) = −[N_g; M_g] written tension-positive with
  // l_j from the base to the platform joint is F_j = x_j − m_T g·l_j.
  for (int j = 0; j < 6; ++j) x[j] -= m.strut_equivalent_mass_kg * g.dot(f.unit[j]);
  return x;
}

Vector6d StrutCompliance(const MachinePhysics& m, const StrutFrame& f, double k_stiff2_mm_per_N) {
  Vector6d k;
  for (int j = 0; j < 6; ++j) {
    k[j] = m.compliance_screw_mm_per_N * (f.length_mm[j] - m.platform_joint_length_mm) /
               m.ball_screw_length_mm +
           k_stiff2_mm_per_N;
  }
  return k;
}

}  // namespace km::hexapod
