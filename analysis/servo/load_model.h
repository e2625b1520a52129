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
// and the base-joint friction of eqs. 3.11–3.12 (analysis/hexapod/joint_swing.h): the torque
// f_t,j = t0 + t1·ĝ_j (N·m; ĝ_j the strut's axial gravity force, tension positive — the struts
// of a hanging platform are in tension) acts as one force of size f_t,j/L_j (L_j in m) at the
// platform joint, normal to the strut, against the joint's swing L_j dl_j/dt:
// −(f_t,j/L_j)·unit(L_j dl_j/dt). Its wrench about the tool tip reaches the struts through Γ⁻¹.
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

// The load on each base joint, |ĝ_j| (N; ĝ_j the static axial gravity force of the strut with
// the current parameters), and whether its friction torque t0 + t1·|ĝ_j| is positive with them
// (eq. 3.12 as JointFrictionTorque of joint_swing.h reads it: a pushed strut loads its joint as a
// pulled one does); a joint where the sum is not positive carries no friction.
struct JointLoads {
  std::array<double, 6> gravity_N{};
  std::array<bool, 6> active{};
};
JointLoads JointLoadsOf(const hexapod::Vector6d& gravity_N, double t0_Nm, double t1_m);

// Rows A (6 × parameters) and the known part c for one sample. The t1 column of joint j is |ĝ_j|
// times its t0 column; both are zero unless loads.active[j]. The screw friction column of strut
// j is zero unless use.screw[j], the joint friction columns unless use.joints. The joint
// friction's direction is unit(swing) (eq. 3.11), or the ramp states `joint_states` (r_j, one
// per joint, friction_states.h) when given.
void LoadRegressor(const hexapod::MachinePhysics& m, const MotionSample& s, double tool_length_mm,
                   const JointLoads& loads, const RowUse& use, LoadRows& a, hexapod::Vector6d& c,
                   const std::array<Eigen::Vector3d, 6>* joint_states = nullptr);

// The wrench on the platform (force N; moment N·mm about the tool tip) of a friction torque of
// 1 N·m in strut j's base joint, against the joint's swing: a force of 1/L_j N (L_j in m)
// along −unit(L_j dl_j/dt) at the platform joint (zero when it does not swing).
hexapod::Vector6d JointFrictionWrench(const MotionSample& s, int j);

// The same with the friction direction state r of a ramp (joint_swing.h StepSwingState, |r| <= 1
// in the plane normal to the strut): the force −r/L_j. Linear in r; r = unit(swing) above.
hexapod::Vector6d JointFrictionWrench(const MotionSample& s, int j, const Eigen::Vector3d& r);

// The 6 × 3 wrenches of JointFrictionWrench(s, j, r) for r = e_x, e_y, e_z, so that the wrench
// of a state r is this × r.
Eigen::Matrix<double, 6, 3> JointFrictionWrenchMap(const MotionSample& s, int j);

// Static axial gravity forces ĝ (eqs. 3.5–3.8) of the sample's pose with the parameters θ.
hexapod::Vector6d StaticGravity(const hexapod::MachinePhysics& m, const LoadVector& theta,
                                const MotionSample& s, double tool_length_mm);

// The parts of one sample's model that do not depend on θ nor on the joints' friction
// directions, with Γ⁻¹ applied once: for fits that evaluate the model at many θ or ramps.
struct SampleLoads {
  Eigen::Matrix<double, 6, 5> gravity;    // columns m_P, m_PΔc, m_S with gravity g (for ĝ)
  Eigen::Matrix<double, 6, 5> effective;  // the same with the effective gravity g − a
  hexapod::Vector6d known;                // c
  hexapod::Vector6d strut;                // the m_T column, −g·l_j
  hexapod::Matrix6d gamma_inv;            // Γ⁻¹ (wrench → strut forces)
};
SampleLoads PrepareSampleLoads(const hexapod::MachinePhysics& m, const MotionSample& s,
                               double tool_length_mm);

// StaticGravity from the prepared parts.
hexapod::Vector6d StaticGravity(const SampleLoads& p, const LoadVector& theta);

// The t0 and t1 columns of LoadRegressor alone (every row), written into `a`: for fits that
// try several friction directions with the other columns unchanged.
void JointColumns(const SampleLoads& p, const MotionSample& s, const JointLoads& loads,
                  const RowUse& use, LoadRows& a,
                  const std::array<Eigen::Vector3d, 6>* joint_states = nullptr);

// LoadRegressor from the prepared parts; `inertia` false: the acceleration taken as zero.
void LoadRegressor(const SampleLoads& p, const MotionSample& s, const JointLoads& loads,
                   const RowUse& use, bool inertia, LoadRows& a, hexapod::Vector6d& c,
                   const std::array<Eigen::Vector3d, 6>* joint_states = nullptr);

}  // namespace km::servo
