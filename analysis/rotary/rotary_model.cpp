#include "analysis/rotary/rotary_model.h"

#include <cmath>

namespace km::rotary {
namespace {

using Eigen::Vector3d;

struct Turn {
  double cos = 1.0;
  double sin = 0.0;
};

Turn TurnOf(double angle_rad) {
  return Turn{std::cos(angle_rad), std::sin(angle_rad)};
}

bool IsIdentity(Turn t) {
  return t.sin == 0.0 && t.cos == 1.0;
}

// Rodrigues: r cos θ + (u × r) sin θ + u (u·r)(1 − cos θ), u a unit vector.
Vector3d Rotate(const Vector3d& u, Turn t, const Vector3d& r) {
  return r * t.cos + u.cross(r) * t.sin + u * (u.dot(r) * (1.0 - t.cos));
}

// T(x) = q + R(u, θ)(x − q); exactly x at zero angle.
Vector3d Apply(const AxisLine& line, Turn t, const Vector3d& x) {
  if (IsIdentity(t)) return x;
  return line.point_mm + Rotate(line.direction, t, x - line.point_mm);
}

// d T(x) / d q along dq: (I − R) dq.
Vector3d PointDerivative(const AxisLine& line, Turn t, const Vector3d& dq) {
  if (IsIdentity(t)) return Vector3d::Zero();
  return dq - Rotate(line.direction, t, dq);
}

// d T(x) / d v along dv, v the direction before normalisation (u = v / |v|).
Vector3d DirectionDerivative(const AxisLine& line, Turn t, const Vector3d& x, const Vector3d& dv) {
  if (IsIdentity(t)) return Vector3d::Zero();
  const Vector3d& u = line.direction;
  const Vector3d du = (dv - u * u.dot(dv)) / line.raw_direction.norm();
  const Vector3d r = x - line.point_mm;
  return du.cross(r) * t.sin + (du * u.dot(r) + u * du.dot(r)) * (1.0 - t.cos);
}

// How each of a line's four errors moves it: the point per µm (mm), the raw direction per µrad.
struct LineErrorAxes {
  Vector3d point[2];
  Vector3d direction[2];
};

LineErrorAxes TiltErrorAxes(Kinematics k) {
  if (k == Kinematics::kAcTrunnion) {  // YOA, ZOA; BOA → −Z, COA → +Y
    return LineErrorAxes{{Vector3d::UnitY(), Vector3d::UnitZ()},
                         {-Vector3d::UnitZ(), Vector3d::UnitY()}};
  }
  // XOB, ZOB; AOB → +Z, COB → −X
  return LineErrorAxes{{Vector3d::UnitX(), Vector3d::UnitZ()},
                       {Vector3d::UnitZ(), -Vector3d::UnitX()}};
}

// XOC, YOC; AOC → −Y, BOC → +X
LineErrorAxes CErrorAxes() {
  return LineErrorAxes{{Vector3d::UnitX(), Vector3d::UnitY()},
                       {-Vector3d::UnitY(), Vector3d::UnitX()}};
}

AxisLine MakeLine(const Vector3d& nominal_point, const Vector3d& nominal_direction,
                  const LineErrorAxes& axes, const double* errors) {
  AxisLine line;
  line.point_mm = nominal_point + 1e-3 * (errors[0] * axes.point[0] + errors[1] * axes.point[1]);
  line.raw_direction =
      nominal_direction + 1e-6 * (errors[2] * axes.direction[0] + errors[3] * axes.direction[1]);
  line.direction = line.raw_direction.normalized();
  return line;
}

}  // namespace

std::string_view KinematicsName(Kinematics k) {
  return k == Kinematics::kAcTrunnion ? "AC-trunnion" : "BC-trunnion";
}

char TiltLetter(Kinematics k) {
  return k == Kinematics::kAcTrunnion ? 'A' : 'B';
}

const std::array<std::string_view, kLocationErrorCount>& LocationErrorNames(Kinematics k) {
  static const std::array<std::string_view, kLocationErrorCount> kAc{
      {"YOA", "ZOA", "BOA", "COA", "XOC", "YOC", "AOC", "BOC"}};
  static const std::array<std::string_view, kLocationErrorCount> kBc{
      {"XOB", "ZOB", "AOB", "COB", "XOC", "YOC", "AOC", "BOC"}};
  return k == Kinematics::kAcTrunnion ? kAc : kBc;
}

AxisLines ActualLines(const RotarySetup& setup, const LocationErrors& errors) {
  const bool ac = setup.kinematics == Kinematics::kAcTrunnion;
  const auto& t = setup.tilt_axis_mm;
  const Vector3d tilt_point = ac ? Vector3d(0.0, t[0], t[1]) : Vector3d(t[0], 0.0, t[1]);
  const Vector3d tilt_direction = ac ? Vector3d::UnitX() : Vector3d::UnitY();
  AxisLines lines;
  lines.tilt = MakeLine(tilt_point, tilt_direction, TiltErrorAxes(setup.kinematics), &errors[0]);
  const Vector3d c_point(setup.c_axis_mm[0], setup.c_axis_mm[1], 0.0);
  lines.c = MakeLine(c_point, Vector3d::UnitZ(), CErrorAxes(), &errors[4]);
  return lines;
}

Vector3d SpherePosition(const AxisLines& lines, const Vector3d& sphere_mm, double tilt_rad,
                        double c_rad) {
  return Apply(lines.tilt, TurnOf(tilt_rad), Apply(lines.c, TurnOf(c_rad), sphere_mm));
}

Vector3d PredictedDisplacement(const RotarySetup& setup, const LocationErrors& errors,
                               double tilt_rad, double c_rad) {
  const Vector3d s(setup.sphere_mm[0], setup.sphere_mm[1], setup.sphere_mm[2]);
  const Vector3d actual = SpherePosition(ActualLines(setup, errors), s, tilt_rad, c_rad);
  const Vector3d nominal = SpherePosition(ActualLines(setup, LocationErrors{}), s, tilt_rad, c_rad);
  return 1e3 * (actual - nominal);
}

PoseLinearisation LinearisePose(Kinematics kinematics, const AxisLines& actual,
                                const Vector3d& sphere_mm, const Vector3d& nominal_position_mm,
                                double tilt_rad, double c_rad) {
  const LineErrorAxes tilt_axes = TiltErrorAxes(kinematics);
  const LineErrorAxes c_axes = CErrorAxes();
  const Turn tt = TurnOf(tilt_rad);
  const Turn tc = TurnOf(c_rad);
  const Vector3d y = Apply(actual.c, tc, sphere_mm);
  PoseLinearisation out;
  out.displacement_um = 1e3 * (Apply(actual.tilt, tt, y) - nominal_position_mm);
  // µm per µm: 1e3 (mm → µm) × 1e-3 (µm → mm); µm per µrad: 1e3 × 1e-6.
  for (int i = 0; i < 2; ++i) {
    out.jacobian.col(i) = PointDerivative(actual.tilt, tt, tilt_axes.point[i]);
    out.jacobian.col(2 + i) =
        1e-3 * DirectionDerivative(actual.tilt, tt, y, tilt_axes.direction[i]);
    const Vector3d dy_point = PointDerivative(actual.c, tc, c_axes.point[i]);
    const Vector3d dy_dir =
        1e-3 * DirectionDerivative(actual.c, tc, sphere_mm, c_axes.direction[i]);
    // The tilt axis carries the C line: a change at y turns with it.
    out.jacobian.col(4 + i) =
        IsIdentity(tt) ? dy_point : Rotate(actual.tilt.direction, tt, dy_point);
    out.jacobian.col(6 + i) = IsIdentity(tt) ? dy_dir : Rotate(actual.tilt.direction, tt, dy_dir);
  }
  return out;
}

}  // namespace km::rotary
