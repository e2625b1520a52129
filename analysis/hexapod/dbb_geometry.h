// Geometry shared by the hexapod DBB simulation and calibration (docs/formats.md §1.1, [PM-600
// report] §2.3):
//
//   plane axes (e1, e2, n): XY → (x, y, z), YZ → (y, z, x), ZX → (z, x, y)
//   commanded moving ball  M(θ) = c + z_offset·n + R·(cos θ·e1 + sin θ·e2)
//   nominal fixed ball     F = c  (the commanded circle centre, docs/formats.md §1.1 `centre_mm`)
//   commanded tool pose    T(θ) = (M(θ), A, B, C) with the test's tilt
//
// and the circularity of a trace ([PM-600 report] eqs. 4.6–4.8): X_n = (R + ΔR_n) cos θ_n,
// Y_n = (R + ΔR_n) sin θ_n, least-squares circle (X0, Y0, R0), circularity = range of
// |(X_n, Y_n) − (X0, Y0)| − R0 (the R/R_DBB factors of eqs. 4.7 and 4.8 cancel). One turn is
// used: samples whose angle lies within 360° of the first sample (half-open).
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

#include "analysis/dbb/dbb_types.h"
#include "analysis/hexapod/kinematics.h"

namespace km::hexapod {

// (e1, e2, n) of the test plane.
std::array<Eigen::Vector3d, 3> DbbPlaneAxes(dbb::Plane plane);

// Commanded tool-tip pose at angle θ (rad) of the test.
Pose CommandedDbbPose(const dbb::DbbTest& test, double angle_rad);

struct TraceCircle {
  Eigen::Vector2d centre_um = Eigen::Vector2d::Zero();  // (X0, Y0) relative to the centre
  double mean_radial_error_um = 0.0;                    // R0 − R
  double circularity_um = 0.0;                          // eq. 4.8
};

// Least-squares circle figures of one turn of a trace (angles in degrees as in the file).
// Throws km::InvalidInput when fewer than 3 distinct samples are available.
TraceCircle TraceCircleFigures(const std::vector<double>& angle_deg,
                               const std::vector<double>& dr_um, double radius_mm);

}  // namespace km::hexapod
