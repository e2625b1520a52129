#include "analysis/servo/load_model.h"

#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "analysis/hexapod/joint_swing.h"

namespace km::servo {
namespace {

using Wrench = hexapod::Vector6d;

Wrench ForceAt(const Eigen::Vector3d& force, const Eigen::Vector3d& lever) {
  Wrench w;
  w << force, lever.cross(force);
  return w;
}

// The gravity-type columns: platform mass and centre (effective gravity ge), the strut weights
// across the struts (gravity g), strut axial mass; wrench columns are solved through Γ later.
void GravityColumns(const hexapod::MachinePhysics& m, const MotionSample& s, double tool_length_mm,
                    const Eigen::Vector3d& ge, Eigen::Matrix<double, 6, 5>& wrenches,
                    Wrench& known) {
  const auto& f = s.frame;
  const Eigen::Matrix3d r = hexapod::RotationABC(s.pose.abc_rad);
  const Eigen::Vector3d cog0 = r * (m.platform_cog_mm + Eigen::Vector3d(0, 0, tool_length_mm));
  wrenches.setZero();
  wrenches.col(0) = ForceAt(ge, cog0);  // m_P
  for (int k = 0; k < 3; ++k) {         // m_P·Δc_k: a moment only
    wrenches.block<3, 1>(3, 1 + k) = r.col(k).cross(ge);
  }
  known.setZero();
  const Eigen::Vector3d& g = m.g_m_s2;
  for (int j = 0; j < 6; ++j) {
    const double len = f.length_mm[j];
    const Eigen::Vector3d across = g - g.dot(f.unit[j]) * f.unit[j];
    const Wrench w = ForceAt(across, f.lever_mm[j]);
    // w_j of eq. 3.7: m_S enters with −l1/L_j, m_B and m_J are known.
    wrenches.col(4) += (-m.motor_offset_mm / len) * w;
    known +=
        ((m.ball_screw_mass_kg * (len - m.platform_joint_length_mm - 0.5 * m.ball_screw_length_mm) +
          m.joint_mass_kg * len) /
         len) *
        w;
  }
}

}  // namespace

std::string LoadParamName(int p) {
  switch (p) {
    case kPlatformMass:
      return "platform_mass_kg";
    case kCogDx:
      return "platform_cog_mm[0]";
    case kCogDy:
      return "platform_cog_mm[1]";
    case kCogDz:
      return "platform_cog_mm[2]";
    case kMotorMass:
      return "motor_mass_kg";
    case kStrutMass:
      return "strut_equivalent_mass_kg";
    case kT0:
      return "base_joint_torque_Nm";
    case kT1:
      return "base_joint_torque_per_N_m";
    default:
      return "screw_friction_N[" + std::to_string(p - kScrew1) + "]";
  }
}

LoadVector ParametersOf(const hexapod::MachinePhysics& m) {
  LoadVector t = LoadVector::Zero();
  t[kPlatformMass] = m.platform_mass_kg;
  t[kMotorMass] = m.motor_mass_kg;
  t[kStrutMass] = m.strut_equivalent_mass_kg;
  for (int j = 0; j < 6; ++j) t[kScrew1 + j] = m.screw_friction_N[j];
  t[kT0] = m.base_joint_torque_Nm;
  t[kT1] = m.base_joint_torque_per_N_m;
  return t;
}

hexapod::MachinePhysics WithParameters(const hexapod::MachinePhysics& m, const LoadVector& theta) {
  hexapod::MachinePhysics out = m;
  out.platform_mass_kg = theta[kPlatformMass];
  if (theta[kPlatformMass] != 0.0) {
    for (int k = 0; k < 3; ++k) {
      out.platform_cog_mm[k] = m.platform_cog_mm[k] + theta[kCogDx + k] / theta[kPlatformMass];
    }
  }
  out.motor_mass_kg = theta[kMotorMass];
  out.strut_equivalent_mass_kg = theta[kStrutMass];
  for (int j = 0; j < 6; ++j) out.screw_friction_N[j] = theta[kScrew1 + j];
  out.base_joint_torque_Nm = theta[kT0];
  out.base_joint_torque_per_N_m = theta[kT1];
  out.has_gravity = out.has_friction = true;
  return out;
}

hexapod::Vector6d JointFrictionWrench(const MotionSample& s, int j, const Eigen::Vector3d& r) {
  // τ_j / L_j with τ in N·m and L_j in m.
  return ForceAt(-(1e3 / s.frame.length_mm[j]) * r, s.frame.lever_mm[j]);
}

hexapod::Vector6d JointFrictionWrench(const MotionSample& s, int j) {
  const Eigen::Vector3d& v = s.swing_mm_s[j];
  const double speed = v.norm();
  if (!(speed > 0.0)) return Wrench::Zero();
  return JointFrictionWrench(s, j, v / speed);
}

Eigen::Matrix<double, 6, 3> JointFrictionWrenchMap(const MotionSample& s, int j) {
  Eigen::Matrix<double, 6, 3> w;
  for (int k = 0; k < 3; ++k) w.col(k) = JointFrictionWrench(s, j, Eigen::Vector3d::Unit(k));
  return w;
}

JointLoads JointLoadsOf(const hexapod::Vector6d& gravity_N, double t0_Nm, double t1_m) {
  JointLoads out;
  for (int j = 0; j < 6; ++j) {
    out.gravity_N[j] = std::abs(gravity_N[j]);  // the load on the joint (eq. 3.12)
    out.active[j] = hexapod::JointFrictionTorque(t0_Nm, t1_m, gravity_N[j]) > 0.0;
  }
  return out;
}

void LoadRegressor(const hexapod::MachinePhysics& m, const MotionSample& s, double tool_length_mm,
                   const JointLoads& loads, const RowUse& use, LoadRows& a, hexapod::Vector6d& c,
                   const std::array<Eigen::Vector3d, 6>* joint_states) {
  const auto& f = s.frame;
  const Eigen::Vector3d ge = m.g_m_s2 - s.accel_mm_s2 * 1e-3;
  Eigen::Matrix<double, 6, 7> w;  // wrench columns: m_P, m_PΔc (3), m_S, t0, t1
  Eigen::Matrix<double, 6, 5> gw;
  Wrench known;
  GravityColumns(m, s, tool_length_mm, ge, gw, known);
  w.leftCols<5>() = gw;
  w.col(5).setZero();
  w.col(6).setZero();
  for (int j = 0; use.joints && j < 6; ++j) {
    if (!loads.active[j]) continue;
    // Base-joint friction torque t0 + t1·ĝ_j (N·m, eq. 3.12) as one force across the strut at
    // the platform joint, against its swing (eq. 3.11).
    const Wrench per_torque =
        joint_states ? JointFrictionWrench(s, j, (*joint_states)[j]) : JointFrictionWrench(s, j);
    w.col(5) += per_torque;
    w.col(6) += loads.gravity_N[j] * per_torque;
  }
  const Eigen::PartialPivLU<hexapod::Matrix6d> lu(f.gamma);
  const Eigen::Matrix<double, 6, 7> x = lu.solve(w);
  c = lu.solve(known);
  a.setZero();
  a.leftCols<5>() = x.leftCols<5>();
  a.col(kT0) = x.col(5);
  a.col(kT1) = x.col(6);
  for (int j = 0; j < 6; ++j) {
    a(j, kStrutMass) = -m.g_m_s2.dot(f.unit[j]);  // eq. 3.8, tension positive
    const double r = s.strut_rate_mm_s[j];
    if (use.screw[j]) a(j, kScrew1 + j) = r > 0.0 ? -1.0 : (r < 0.0 ? 1.0 : 0.0);  // eq. 3.10
  }
}

hexapod::Vector6d StaticGravity(const hexapod::MachinePhysics& m, const LoadVector& theta,
                                const MotionSample& s, double tool_length_mm) {
  Eigen::Matrix<double, 6, 5> gw;
  Wrench known;
  GravityColumns(m, s, tool_length_mm, m.g_m_s2, gw, known);
  Eigen::Matrix<double, 5, 1> th;
  th << theta[kPlatformMass], theta[kCogDx], theta[kCogDy], theta[kCogDz], theta[kMotorMass];
  const Eigen::PartialPivLU<hexapod::Matrix6d> lu(s.frame.gamma);
  hexapod::Vector6d x = lu.solve(gw * th + known);
  for (int j = 0; j < 6; ++j) x[j] -= theta[kStrutMass] * m.g_m_s2.dot(s.frame.unit[j]);
  return x;
}

SampleLoads PrepareSampleLoads(const hexapod::MachinePhysics& m, const MotionSample& s,
                               double tool_length_mm) {
  const auto& f = s.frame;
  const Eigen::PartialPivLU<hexapod::Matrix6d> lu(f.gamma);
  SampleLoads p;
  Eigen::Matrix<double, 6, 5> gw;
  Wrench known;
  GravityColumns(m, s, tool_length_mm, m.g_m_s2 - s.accel_mm_s2 * 1e-3, gw, known);
  p.effective = lu.solve(gw);
  p.known = lu.solve(known);
  GravityColumns(m, s, tool_length_mm, m.g_m_s2, gw, known);
  p.gravity = lu.solve(gw);
  for (int j = 0; j < 6; ++j) p.strut[j] = -m.g_m_s2.dot(f.unit[j]);
  p.gamma_inv = lu.inverse();
  return p;
}

hexapod::Vector6d StaticGravity(const SampleLoads& p, const LoadVector& theta) {
  return p.gravity * theta.head<5>() + p.known + theta[kStrutMass] * p.strut;
}

void JointColumns(const SampleLoads& p, const MotionSample& s, const JointLoads& loads,
                  const RowUse& use, LoadRows& a,
                  const std::array<Eigen::Vector3d, 6>* joint_states) {
  Wrench w0 = Wrench::Zero(), w1 = Wrench::Zero();
  for (int j = 0; use.joints && j < 6; ++j) {
    if (!loads.active[j]) continue;
    const Wrench per_torque =
        joint_states ? JointFrictionWrench(s, j, (*joint_states)[j]) : JointFrictionWrench(s, j);
    w0 += per_torque;
    w1 += loads.gravity_N[j] * per_torque;
  }
  a.col(kT0) = p.gamma_inv * w0;
  a.col(kT1) = p.gamma_inv * w1;
}

void LoadRegressor(const SampleLoads& p, const MotionSample& s, const JointLoads& loads,
                   const RowUse& use, bool inertia, LoadRows& a, hexapod::Vector6d& c,
                   const std::array<Eigen::Vector3d, 6>* joint_states) {
  a.setZero();
  a.leftCols<5>() = inertia ? p.effective : p.gravity;
  a.col(kStrutMass) = p.strut;
  JointColumns(p, s, loads, use, a, joint_states);
  for (int j = 0; j < 6; ++j) {
    const double r = s.strut_rate_mm_s[j];
    if (use.screw[j]) a(j, kScrew1 + j) = r > 0.0 ? -1.0 : (r < 0.0 ? 1.0 : 0.0);  // eq. 3.10
  }
  c = p.known;
}

}  // namespace km::servo
