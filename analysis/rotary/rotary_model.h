// The forward model of an R-test on a trunnion table (docs/methods.md §17.1; [ISO 230-1] location
// errors, [ISO 10791-6] R-test): the sphere is carried by the rotary axes about their actual
// lines, the linear axes are ideal.
//
//   p(t, c) = T_tilt(t) ∘ T_C(c) (s),   T(x) = q + R(u, angle)(x − q)
//
// with s the sphere's centre at zero angles, q a point of the axis line and u its unit direction,
// R(u, θ) the right-handed rotation about u by θ (Rodrigues:
// R r = r cos θ + (u × r) sin θ + u (u·r)(1 − cos θ)). The nest is held at the nominal position,
// the same composition about the nominal lines; the displacement is actual − nominal, µm.
//
// The actual lines, from the location errors (µm → mm × 1e-3, µrad → rad × 1e-6):
//   A (AC): q = (0, y_A + YOA, z_A + ZOA), u ∥ (1, COA, −BOA)    (crosses X = 0 at q)
//   B (BC): q = (x_B + XOB, 0, z_B + ZOB), u ∥ (−COB, 1, AOB)    (crosses Y = 0 at q)
//   C:      q = (x_C + XOC, y_C + YOC, 0), u ∥ (BOC, −AOC, 1)    (at zero tilt, crosses Z = 0)
// each direction normalised. The C line is carried by the tilt axis: it is where it is at zero
// tilt, and T_tilt moves it with the table.
#pragma once

#include <Eigen/Core>

#include "analysis/rotary/rotary_types.h"

namespace km::rotary {

struct AxisLine {
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d raw_direction = Eigen::Vector3d::UnitZ();  // before normalisation
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();      // unit
};

struct AxisLines {
  AxisLine tilt;
  AxisLine c;
};

// The actual lines of the location errors (all zero: the nominal lines).
AxisLines ActualLines(const RotarySetup& setup, const LocationErrors& errors);

// Where the rotary axes carry the sphere (mm) at the tilt and C angles (radians).
Eigen::Vector3d SpherePosition(const AxisLines& lines, const Eigen::Vector3d& sphere_mm,
                               double tilt_rad, double c_rad);

// The displacement actual − nominal of the sphere at one pose, µm.
Eigen::Vector3d PredictedDisplacement(const RotarySetup& setup, const LocationErrors& errors,
                                      double tilt_rad, double c_rad);

using DisplacementJacobian = Eigen::Matrix<double, 3, static_cast<int>(kLocationErrorCount)>;

// The displacement (µm) at one pose and its derivatives with respect to the eight location
// errors (µm per µm, µm per µrad), exact for the model above.
struct PoseLinearisation {
  Eigen::Vector3d displacement_um = Eigen::Vector3d::Zero();
  DisplacementJacobian jacobian = DisplacementJacobian::Zero();
};

// `actual` and `nominal_position_mm` as ActualLines / SpherePosition give them for the pose.
PoseLinearisation LinearisePose(Kinematics kinematics, const AxisLines& actual,
                                const Eigen::Vector3d& sphere_mm,
                                const Eigen::Vector3d& nominal_position_mm, double tilt_rad,
                                double c_rad);

}  // namespace km::rotary
