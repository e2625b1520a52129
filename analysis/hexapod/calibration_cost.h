// Residual of one DBB sample for hexapod calibration (see calibration.h for the model); the
// Ceres cost function around it is in calibration_ceres.cpp:
//
//   r = 1000·(|tip(FK_{nominal+K}(s)) − F| − L_measured)            [µm]
//   ∂r/∂Δo_j = w_j,  ∂r/∂ΔQ_j = w_j·u_jᵀ  (K in µm),  ∂r/∂F = −1000·eᵀ (F in mm)
//   w = J⁻ᵀ·[e; 0; 0; 0],  J = ∂s/∂T at the real pose,  e = unit bar vector
//
// Analytic Jacobian (implicit function theorem on IK_K(T') = s); checked against numerical
// differentiation in tests/unit/hexapod.
#pragma once

#include <Eigen/Dense>

#include "analysis/core/errors.h"
#include "analysis/hexapod/calibration_sample.h"
#include "analysis/hexapod/kinematics.h"

namespace km::hexapod {

// Residual and (optional) derivatives of one sample. Returns false when the forward kinematics
// fails (near-singular candidate parameters).
inline bool EvaluateBarSample(const HexapodGeometry& nominal, const CalibrationSample& sample,
                              double tool_length_mm, const double* k_um, const double* f_mm,
                              double* residual_um, double* d_dk /* 24 or null */,
                              double* d_df /* 3 or null */) {
  HexapodGeometry g = nominal;
  for (int j = 0; j < 6; ++j) {
    g.strut_offset_mm[j] += 1e-3 * k_um[j];
    for (int c = 0; c < 3; ++c) g.base_joints_mm[j][c] += 1e-3 * k_um[6 + 3 * j + c];
  }
  ForwardResult fk;
  try {
    fk = ForwardKinematics(g, sample.strut_command_mm, tool_length_mm, sample.commanded);
  } catch (const DidNotConverge&) {
    return false;
  }
  const Eigen::Vector3d F(f_mm[0], f_mm[1], f_mm[2]);
  const Eigen::Vector3d v = fk.pose.tip_mm - F;
  const double bar = v.norm();
  *residual_um = 1000.0 * (bar - sample.measured_bar_mm);
  if (d_dk == nullptr && d_df == nullptr) return true;
  const Eigen::Vector3d e = v / bar;
  if (d_df) {
    for (int c = 0; c < 3; ++c) d_df[c] = -1000.0 * e[c];
  }
  if (d_dk) {
    const Matrix6d& J = fk.jacobian;  // row j = [u_jᵀ, ∂s_j/∂(A,B,C)]
    Vector6d rhs = Vector6d::Zero();
    rhs.head<3>() = e;
    const Vector6d w = J.transpose().partialPivLu().solve(rhs);
    for (int j = 0; j < 6; ++j) {
      d_dk[j] = w[j];
      for (int c = 0; c < 3; ++c) d_dk[6 + 3 * j + c] = w[j] * J(j, c);
    }
  }
  return true;
}

}  // namespace km::hexapod
