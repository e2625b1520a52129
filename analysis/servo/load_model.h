// Strut motor forces of a hexapod as a linear function of its mass and friction parameters
// ([PM-600 report] eqs. 3.2–3.13, docs/methods.md §12). With the geometry known, the axial
// motor force of strut j at a sample (tension positive, N) is
//
//   F_j = [A θ]_j + c_j + d_j
//
// with d the external (cutting) load and θ the parameters below. The platform's weight and
// inertia enter through the effective gravity g − a (a = tool-tip acceleration, eq. 3.13); the
// centre of gravity as m_P·Δc, its offset from the machine definition's value (so a centre the
// data cannot separate is held at that value); the strut weights split between their joints
// (eqs. 3.6–3.7) with the ball-screw and joint masses m_B, m_J held at the machine's values; the
// strut equivalent mass m_T (eq. 3.8); the ball-screw friction −f0_j sign(dL_j/dt) (eq. 3.10);
// the base-joint friction torque τ_j = t0 + t1·|ĝ_j| acting across the strut against the
// platform joint's swing (eqs. 3.11–3.12; the report writes t1·ĝ_j, and ĝ_j is tension,
// positive, on a hanging platform), as a force −(τ_j/L_j) Σ_k sign(swing_k) a_k on each of the
// joint's two swing axes (docs/hexapod-effects.md § joint_friction, after its ramp).
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>

#include "analysis/hexapod/statics.h"
#include "analysis/servo/hexapod_motion.h"

namespace km::servo {

enum LoadParam : int {
  kPlatformMass = 0,  // m_P, kg
  kCogDx,             // m_P·Δc_x, kg·mm (platform frame)
  kCogDy,
  kCogDz,
  kMotorMass,         // m_S, kg
  kStrutMass,         // m_T, kg
  kScrew1,            // f0_1 … f0_6, N
  kT0 = kScrew1 + 6,  // N·m
  kT1,                // m
  kNumLoadParams
};

using LoadVector = Eigen::Matrix<double, kNumLoadParams, 1>;
using LoadRows = Eigen::Matrix<double, 6, kNumLoadParams>;

// Name of a parameter (the machine definition's key, with the strut for f0_j).
std::string LoadParamName(int p);

// θ of a machine definition's gravity and friction blocks (Δc = 0).
LoadVector ParametersOf(const hexapod::MachinePhysics& m);

// The machine's physics with θ written into it (centre of gravity = machine value + Δc).
hexapod::MachinePhysics WithParameters(const hexapod::MachinePhysics& m, const LoadVector& theta);

// Rows A (6 × parameters) and the known part c for one sample. `abs_gravity_N` is |ĝ_j|, the
// static axial gravity force of each strut with the current parameters (for t1). The screw
// friction column of strut j is zero unless use.screw[j], the joint friction columns unless
// use.joints.
void LoadRegressor(const hexapod::MachinePhysics& m, const MotionSample& s, double tool_length_mm,
                   const std::array<double, 6>& abs_gravity_N, const RowUse& use, LoadRows& a,
                   hexapod::Vector6d& c);

// The wrench on the platform (force N; moment N·mm about the tool tip) of a friction torque of
// 1 N·m in strut j's base joint, against the joint's swing (zero when it does not swing).
hexapod::Vector6d JointFrictionWrench(const MotionSample& s, int j);

// Static axial gravity forces ĝ (eqs. 3.5–3.8) of the sample's pose with the parameters θ.
hexapod::Vector6d StaticGravity(const hexapod::MachinePhysics& m, const LoadVector& theta,
                                const MotionSample& s, double tool_length_mm);

}  // namespace km::servo
