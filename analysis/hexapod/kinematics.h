// Stewart-platform (hexapod) kinematics, [PM-600 report] §1.4.
//
//   pose T = (X, Y, Z, A, B, C) of the TOOL TIP, R = Rx(A)·Ry(B)·Rz(C)            (eq. 1.4)
//   platform frame: origin at the spindle nose, z up the spindle axis, tool tip at (0,0,−l)
//   platform joint in the machine frame  P_j = X + R·(p_j + (0,0,l))            (eq. 1.1)
//   strut vector  L_j = P_j − Q_j,  joint-to-joint length d_j = |L_j|           (eqs. 1.2–1.3)
//
// Strut-offset convention (consistent with docs/formats.md §3, `strut_offset_um` = true strut
// length − length the nominal model commands): the controller commands the actuator value
//
//   s_j = d_j − o_j ,
//
// and a machine whose offset is o_j realises the joint-to-joint distance d_j = s_j + o_j. A model
// with o = 0 (the nominal pm600-like file) therefore commands s_j = d_j; a real machine with
// offset o_j then realises d_j + o_j, i.e. o_j is "true length − commanded length".
//
// Inverse kinematics (T → s) is closed form. Forward kinematics (s → T) is Newton's method with
// the analytic Jacobian J = ∂s/∂T (eq. 1.5, here 6×6 with rows = struts, columns = X..C), with
// a residual check: a pose is returned only when every strut length is reproduced to the
// tolerance; otherwise km::DidNotConverge. The reported condition number scales the angle
// columns by a characteristic length (mean platform-joint radius) so all columns are in mm.
#pragma once

#include <array>

#include <Eigen/Core>

namespace km::hexapod {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Kinematic parameters of one machine (nominal model, true machine or calibrated model).
struct HexapodGeometry {
  std::array<Eigen::Vector3d, 6> base_joints_mm;      // Q_j, machine frame
  std::array<Eigen::Vector3d, 6> platform_joints_mm;  // p_j, platform frame
  std::array<double, 6> strut_offset_mm{};            // o_j, see the convention above
};

// Tool-tip pose. Angles in radians (A about x, B about y, C about z).
struct Pose {
  Eigen::Vector3d tip_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d abc_rad = Eigen::Vector3d::Zero();

  Vector6d AsVector() const;
  static Pose FromVector(const Vector6d& v);
};

// R = Rx(A)·Ry(B)·Rz(C), [PM-600 report] eq. 1.4.
Eigen::Matrix3d RotationABC(const Eigen::Vector3d& abc_rad);
// ∂R/∂A, ∂R/∂B, ∂R/∂C.
std::array<Eigen::Matrix3d, 3> RotationABCDerivatives(const Eigen::Vector3d& abc_rad);

// Platform joints in the machine frame, P_j = X + R·(p_j + (0,0,l)).
std::array<Eigen::Vector3d, 6> PlatformJointsInMachine(const HexapodGeometry& g, const Pose& pose,
                                                       double tool_length_mm);

// Commanded actuator values s_j = |P_j − Q_j| − o_j (closed-form inverse kinematics).
Vector6d InverseKinematics(const HexapodGeometry& g, const Pose& pose, double tool_length_mm);

// J = ∂s/∂T (rows: struts; columns: X, Y, Z [mm], A, B, C [rad]), eq. 1.5 transposed.
Matrix6d PoseJacobian(const HexapodGeometry& g, const Pose& pose, double tool_length_mm);

// Unit strut vectors u_j = (P_j − Q_j)/|P_j − Q_j|; ∂s_j/∂Q_j = −u_jᵀ and ∂s_j/∂o_j = −1.
std::array<Eigen::Vector3d, 6> StrutDirections(const HexapodGeometry& g, const Pose& pose,
                                               double tool_length_mm);

// Mean distance of the platform joints from the spindle axis (the characteristic length).
double CharacteristicLengthMm(const HexapodGeometry& g);

// 2-norm condition number of J with the angle columns multiplied by 1/characteristic length.
double JacobianConditionNumber(const HexapodGeometry& g, const Pose& pose, double tool_length_mm);

struct ForwardOptions {
  int max_iterations = 50;
  double strut_tolerance_mm = 1e-10;     // every |s_j(T) − s_j| must end below this
  double step_tolerance_mm = 1e-9;       // last position step (angles × characteristic length)
  double max_condition_number = 1e5;     // above this (1-norm estimate) the pose is refused
  bool report_condition_number = false;  // also compute the 2-norm figure (an SVD, ~µs)
  void Check() const;  // throws km::InvalidInput naming the option out of its range
};

struct ForwardResult {
  Pose pose;
  int iterations = 0;
  double max_strut_residual_mm = 0.0;
  double condition_number = 0.0;         // 2-norm at the solution, when requested (else 0)
  Matrix6d jacobian = Matrix6d::Zero();  // J = ∂s/∂T at the solution (rows j: [u_jᵀ, …])
};

// Newton forward kinematics from `initial`. Throws km::DidNotConverge when the iteration does not
// reproduce the strut lengths, or when the Jacobian is (near) singular at the solution.
ForwardResult ForwardKinematics(const HexapodGeometry& g, const Vector6d& struts_mm,
                                double tool_length_mm, const Pose& initial,
                                const ForwardOptions& options = {});

}  // namespace km::hexapod
