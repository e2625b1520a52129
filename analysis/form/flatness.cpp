#include "analysis/form/flatness.h"

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"
#include "analysis/geometry/plane_fit.h"

namespace km::form {
namespace {

PlaneReport Report(const geometry::Plane3& p) {
  // um per mm -> um per m.
  return PlaneReport{1000.0 * p.slope_x, 1000.0 * p.slope_y, p.offset};
}

}  // namespace

FlatnessResult AnalyzeFlatness(const Grid& grid) {
  const std::size_t n = grid.x_mm.size();
  if (grid.y_mm.size() != n || grid.z_um.size() != n) {
    throw InvalidInput("", 0, "z_um", "x, y and z differ in number");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(grid.x_mm[i])) throw InvalidInput("", 0, "x_mm", "value is not finite");
    if (!std::isfinite(grid.y_mm[i])) throw InvalidInput("", 0, "y_mm", "value is not finite");
    if (!std::isfinite(grid.z_um[i])) throw InvalidInput("", 0, "z_um", "value is not finite");
  }
  if (n < 3) throw NotObservable("flatness needs at least 3 points");
  FlatnessResult r;
  r.points = n;
  const auto [zmin, zmax] = std::minmax_element(grid.z_um.begin(), grid.z_um.end());
  r.range_um = *zmax - *zmin;
  const geometry::Plane3 lsq = geometry::FitPlaneLeastSquares(grid.x_mm, grid.y_mm, grid.z_um);
  r.flatness_lsq_um = geometry::PeakToValley(grid.x_mm, grid.y_mm, grid.z_um, lsq);
  r.plane = Report(lsq);
  const geometry::MinimumZonePlane zone =
      geometry::FitPlaneMinimumZone(grid.x_mm, grid.y_mm, grid.z_um);
  r.flatness_min_zone_um = zone.width;
  r.min_zone_plane = Report(zone.centre);
  return r;
}

}  // namespace km::form
