#include "analysis/hexapod/kinematics.h"

#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Dense>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"

namespace km::hexapod {

Vector6d Pose::AsVector() const {
  Vector6d v;
  v << tip_mm, abc_rad;
  return v;
}

Pose Pose::FromVector(const Vector6d& v) {
  Pose p;
  p.tip_mm = v.head<3>();
  p.abc_rad = v.tail<3>();
  return p;
}

namespace {

Eigen::Matrix3d Rx(double a) {
  Eigen::Matrix3d m;
  const double c = std::cos(a), s = std::sin(a);
  m << 1, 0, 0, 0, c, -s, 0, s, c;
  return m;
}
Eigen::Matrix3d Ry(double b) {
  Eigen::Matrix3d m;
  const double c = std::cos(b), s = std::sin(b);
  m << c, 0, s, 0, 1, 0, -s, 0, c;
  return m;
}
Eigen::Matrix3d Rz(double g) {
  Eigen::Matrix3d m;
  const double c = std::cos(g), s = std::sin(g);
  m << c, -s, 0, s, c, 0, 0, 0, 1;
  return m;
}
Eigen::Matrix3d dRx(double a) {
  Eigen::Matrix3d m;
  const double c = std::cos(a), s = std::sin(a);
  m << 0, 0, 0, 0, -s, -c, 0, c, -s;
  return m;
}
Eigen::Matrix3d dRy(double b) {
  Eigen::Matrix3d m;
  const double c = std::cos(b), s = std::sin(b);
  m << -s, 0, c, 0, 0, 0, -c, 0, -s;
  return m;
}
Eigen::Matrix3d dRz(double g) {
  Eigen::Matrix3d m;
  const double c = std::cos(g), s = std::sin(g);
  m << -s, -c, 0, c, -s, 0, 0, 0, 0;
  return m;
}

// Struts and Jacobian in one pass (the Newton loop needs both).
void StrutsAndJacobian(const HexapodGeometry& g, const Pose& pose, double tool_length_mm,
                       Vector6d* s, Matrix6d* J) {
  const Eigen::Vector3d& abc = pose.abc_rad;
  const Eigen::Matrix3d rx = Rx(abc[0]), ry = Ry(abc[1]), rz = Rz(abc[2]);
  const Eigen::Matrix3d R = rx * ry * rz;
  Eigen::Matrix3d dA = Eigen::Matrix3d::Zero(), dB = Eigen::Matrix3d::Zero(),
                  dC = Eigen::Matrix3d::Zero();
  if (J) {
    dA = dRx(abc[0]) * ry * rz;
    dB = rx * dRy(abc[1]) * rz;
    dC = rx * ry * dRz(abc[2]);
  }
  for (int j = 0; j < 6; ++j) {
    const Eigen::Vector3d r = g.platform_joints_mm[j] + Eigen::Vector3d(0, 0, tool_length_mm);
    const Eigen::Vector3d L = pose.tip_mm + R * r - g.base_joints_mm[j];
    const double d = L.norm();
    (*s)[j] = d - g.strut_offset_mm[j];
    if (J) {
      const Eigen::Vector3d u = L / d;
      J->block<1, 3>(j, 0) = u.transpose();
      (*J)(j, 3) = u.dot(dA * r);
      (*J)(j, 4) = u.dot(dB * r);
      (*J)(j, 5) = u.dot(dC * r);
    }
  }
}

}  // namespace

Eigen::Matrix3d RotationABC(const Eigen::Vector3d& abc_rad) {
  return Rx(abc_rad[0]) * Ry(abc_rad[1]) * Rz(abc_rad[2]);
}

std::array<Eigen::Matrix3d, 3> RotationABCDerivatives(const Eigen::Vector3d& abc) {
  const Eigen::Matrix3d rx = Rx(abc[0]), ry = Ry(abc[1]), rz = Rz(abc[2]);
  return {dRx(abc[0]) * ry * rz, rx * dRy(abc[1]) * rz, rx * ry * dRz(abc[2])};
}

std::array<Eigen::Vector3d, 6> PlatformJointsInMachine(const HexapodGeometry& g, const Pose& pose,
                                                       double tool_length_mm) {
  const Eigen::Matrix3d R = RotationABC(pose.abc_rad);
  std::array<Eigen::Vector3d, 6> out;
  for (int j = 0; j < 6; ++j) {
    out[j] = pose.tip_mm + R * (g.platform_joints_mm[j] + Eigen::Vector3d(0, 0, tool_length_mm));
  }
  return out;
}

Vector6d InverseKinematics(const HexapodGeometry& g, const Pose& pose, double tool_length_mm) {
  Vector6d s;
  StrutsAndJacobian(g, pose, tool_length_mm, &s, nullptr);
  return s;
}

Matrix6d PoseJacobian(const HexapodGeometry& g, const Pose& pose, double tool_length_mm) {
  Vector6d s;
  Matrix6d J;
  StrutsAndJacobian(g, pose, tool_length_mm, &s, &J);
  return J;
}

std::array<Eigen::Vector3d, 6> StrutDirections(const HexapodGeometry& g, const Pose& pose,
                                               double tool_length_mm) {
  const auto P = PlatformJointsInMachine(g, pose, tool_length_mm);
  std::array<Eigen::Vector3d, 6> u;
  for (int j = 0; j < 6; ++j) u[j] = (P[j] - g.base_joints_mm[j]).normalized();
  return u;
}

double CharacteristicLengthMm(const HexapodGeometry& g) {
  double sum = 0.0;
  for (const auto& p : g.platform_joints_mm) sum += p.head<2>().norm();
  const double r = sum / 6.0;
  return r > 0.0 ? r : 1.0;
}

namespace {
double ScaledCondition(const Matrix6d& J, double char_len) {
  Matrix6d Js = J;
  Js.rightCols<3>() /= char_len;
  const Eigen::JacobiSVD<Matrix6d> svd(Js);
  const auto& sv = svd.singularValues();
  if (sv[5] <= 0.0) return std::numeric_limits<double>::infinity();
  return sv[0] / sv[5];
}
}  // namespace

double JacobianConditionNumber(const HexapodGeometry& g, const Pose& pose, double tool_length_mm) {
  return ScaledCondition(PoseJacobian(g, pose, tool_length_mm), CharacteristicLengthMm(g));
}

void ForwardOptions::Check() const {
  KM_OPTION_GE(max_iterations, 1);
  KM_OPTION_GT(strut_tolerance_mm, 0.0);
  KM_OPTION_GT(step_tolerance_mm, 0.0);
  KM_OPTION_GT(max_condition_number, 1.0);
}

ForwardResult ForwardKinematics(const HexapodGeometry& g, const Vector6d& struts_mm,
                                double tool_length_mm, const Pose& initial,
                                const ForwardOptions& options) {
  options.Check();
  const double char_len = CharacteristicLengthMm(g);
  Vector6d T = initial.AsVector();
  Vector6d s;
  Matrix6d J;
  StrutsAndJacobian(g, Pose::FromVector(T), tool_length_mm, &s, &J);
  Vector6d r = s - struts_mm;
  ForwardResult result;
  double last_step = std::numeric_limits<double>::infinity();
  double rcond = 0.0;
  bool converged = false;
  for (int it = 0; it < options.max_iterations; ++it) {
    const double max_res = r.cwiseAbs().maxCoeff();
    result.iterations = it;
    result.max_strut_residual_mm = max_res;
    // Scale the angle columns so the 1-norm condition estimate is unit-consistent.
    Matrix6d Js = J;
    Js.rightCols<3>() /= char_len;
    const Eigen::PartialPivLU<Matrix6d> lu(Js);
    // The condition estimate (as costly as the factorisation) is taken where it decides: at
    // the solution, and while the iteration is still far from it.
    const bool done =
        max_res <= options.strut_tolerance_mm && last_step <= options.step_tolerance_mm;
    const bool near = max_res <= 1e-3 && it > 0;
    if (done || !near) rcond = lu.rcond();
    if (!std::isfinite(max_res) ||
        ((done || !near) && !(rcond > 1.0 / options.max_condition_number)))
      break;
    if (done) {
      converged = true;
      break;
    }
    Vector6d step = lu.solve(r);  // in scaled units: angles × char_len
    const double step_norm = step.norm();
    step.tail<3>() /= char_len;
    // Backtracking: accept the first step length that does not increase the residual (the
    // full Newton step almost always; halving keeps far starts from diverging).
    const double r_norm = r.norm();
    double alpha = 1.0;
    Vector6d T_new, s_new, r_new;
    Matrix6d J_new;
    for (int k = 0; k < 30; ++k, alpha *= 0.5) {
      T_new = T - alpha * step;
      StrutsAndJacobian(g, Pose::FromVector(T_new), tool_length_mm, &s_new, &J_new);
      r_new = s_new - struts_mm;
      if (r_new.norm() <= r_norm || r_norm <= 100.0 * options.strut_tolerance_mm) break;
    }
    T = T_new;
    J = J_new;
    r = r_new;
    last_step = alpha * step_norm;
  }
  if (!converged) {
    std::ostringstream msg;
    msg << "forward kinematics did not converge after " << result.iterations
        << " iterations (max strut residual " << result.max_strut_residual_mm
        << " mm, condition number estimate " << (rcond > 0 ? 1.0 / rcond : INFINITY)
        << "): pose is near a singularity or outside the reachable workspace";
    throw DidNotConverge(msg.str());
  }
  result.pose = Pose::FromVector(T);
  result.jacobian = J;
  if (options.report_condition_number) result.condition_number = ScaledCondition(J, char_len);
  return result;
}

}  // namespace km::hexapod
