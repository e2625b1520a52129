#include "analysis/hexapod/dbb_geometry.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "analysis/core/errors.h"
#include "analysis/geometry/circle_fit.h"

namespace km::hexapod {

std::array<Eigen::Vector3d, 3> DbbPlaneAxes(dbb::Plane plane) {
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  switch (plane) {
    case dbb::Plane::kYZ:
      return {y, z, x};
    case dbb::Plane::kZX:
      return {z, x, y};
    case dbb::Plane::kXY:
    default:
      return {x, y, z};
  }
}

Pose CommandedDbbPose(const dbb::DbbTest& test, double angle_rad) {
  const auto ax = DbbPlaneAxes(test.plane);
  const double R = test.radius_mm > 0.0 ? test.radius_mm : test.bar_length_mm;
  Pose p;
  p.tip_mm = Eigen::Vector3d(test.centre_mm[0], test.centre_mm[1], test.centre_mm[2]) +
             test.z_offset_mm * ax[2] +
             R * (std::cos(angle_rad) * ax[0] + std::sin(angle_rad) * ax[1]);
  constexpr double kDeg = std::numbers::pi / 180.0;
  p.abc_rad = Eigen::Vector3d(test.tilt_deg[0], test.tilt_deg[1], test.tilt_deg[2]) * kDeg;
  return p;
}

TraceCircle TraceCircleFigures(const std::vector<double>& angle_deg,
                               const std::vector<double>& dr_um, double radius_mm) {
  if (angle_deg.size() != dr_um.size() || angle_deg.size() < 3) {
    throw InvalidInput("", 0, "dr_um", "a circular trace needs at least 3 samples");
  }
  constexpr double kDeg = std::numbers::pi / 180.0;
  const double R_um = radius_mm * 1000.0;
  std::vector<Eigen::Vector2d> pts;
  pts.reserve(angle_deg.size());
  for (std::size_t i = 0; i < angle_deg.size(); ++i) {
    if (std::abs(angle_deg[i] - angle_deg[0]) >= 360.0 - 1e-9) break;  // one turn, half-open
    const double r = R_um + dr_um[i];
    pts.emplace_back(r * std::cos(angle_deg[i] * kDeg), r * std::sin(angle_deg[i] * kDeg));
  }
  const auto fit = geometry::FitCircleLeastSquares(pts);  // eq. 4.6, in µm
  const auto res = geometry::CircleResiduals(pts, fit.circle);
  const auto [lo, hi] = std::minmax_element(res.begin(), res.end());
  TraceCircle out;
  out.centre_um = fit.circle.centre;
  out.mean_radial_error_um = fit.circle.radius - R_um;
  out.circularity_um = *hi - *lo;
  return out;
}

}  // namespace km::hexapod
