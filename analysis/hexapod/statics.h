// Statics of a hexapod platform ([PM-600 report] eqs. 3.4–3.8) and the strut compliance of
// eq. 4.3, as used by the gravity and joint-friction effects (docs/hexapod-effects.md).
//
//   l_j = (P_j − Q_j)/L_j   unit strut vector, base joint → platform joint
//   B_j = P_j − tip          platform joint relative to the tool tip
//   Γ(x) = [Σ x_j l_j ; Σ B_j × x_j l_j]                                       (eq. 3.4)
//
// A strut in tension x_j > 0 pulls the platform towards the base with −x_j l_j, so a wrench
// [N; M] (about the tool tip) applied to the platform is held by the tensions Γ⁻¹[N; M].
#pragma once

#include <array>

#include <Eigen/Core>

#include "analysis/hexapod/kinematics.h"

namespace km::hexapod {

// The `gravity` and `friction` blocks of a machine file (docs/formats.md §2). Units as named.
struct MachinePhysics {
  bool has_gravity = false;
  Eigen::Vector3d g_m_s2{0.0, 0.0, -9.80665};
  double platform_mass_kg = 0.0;
  Eigen::Vector3d platform_cog_mm = Eigen::Vector3d::Zero();  // platform frame
  double ball_screw_mass_kg = 0.0;                            // m_B
  double joint_mass_kg = 0.0;                                 // m_J
  double motor_mass_kg = 0.0;                                 // m_S
  double motor_offset_mm = 0.0;                               // l1
  double platform_joint_length_mm = 0.0;                      // l2
  double ball_screw_length_mm = 1.0;                          // l3
  double strut_equivalent_mass_kg = 0.0;                      // m_T
  double compliance_screw_mm_per_N = 0.0;                     // K_stiff1
  double compliance_other_mm_per_N = 0.0;                     // K_stiff2
  // Standard uncertainties (k = 1) of the inputs a gravity fit holds at the values above: they
  // are propagated into the σ of what it fits (docs/methods.md §5). Defaults until a machine
  // file states its own: K_stiff1 is the report's cylinder approximation of the ball screw
  // (§4.2.1), m_P and B_P the maker's weighing and drawing.
  double u_compliance_screw_rel = 0.01;  // of K_stiff1
  double u_platform_mass_rel = 0.002;    // of m_P
  double u_platform_cog_mm = 0.5;        // each coordinate of B_P
  bool has_friction = false;
  std::array<double, 6> screw_friction_N{};  // f0_j
  double base_joint_torque_Nm = 0.0;         // t0
  double base_joint_torque_per_N_m = 0.0;    // t1
};

// Geometry of the struts at one pose.
struct StrutFrame {
  std::array<Eigen::Vector3d, 6> unit;      // l_j
  std::array<double, 6> length_mm{};        // L_j
  std::array<Eigen::Vector3d, 6> lever_mm;  // B_j
  Matrix6d gamma = Matrix6d::Zero();        // columns [l_j; B_j × l_j] (moments in N·mm)
};

StrutFrame StrutFrameAt(const HexapodGeometry& g, const Pose& pose, double tool_length_mm);

// Strut tensions (N) holding the wrench [force N; moment N·mm about the tool tip].
Vector6d TensionsForWrench(const StrutFrame& f, const Eigen::Vector3d& force_N,
                           const Eigen::Vector3d& moment_Nmm);

// Axial strut forces under gravity, tension positive (eqs. 3.5–3.8): F_j = x_j − m_T g·l_j with
// x the tensions holding the platform's weight and the struts' perpendicular loads.
Vector6d GravityAxialForces(const MachinePhysics& m, const StrutFrame& f, const Pose& pose,
                            double tool_length_mm);

// K_j = K_stiff1 (L_j − l2)/l3 + K_stiff2 (eq. 4.3), mm/N.
Vector6d StrutCompliance(const MachinePhysics& m, const StrutFrame& f, double k_stiff2_mm_per_N);

}  // namespace km::hexapod
