// Flatness of a surface measured as z_um at grid points (x_mm, y_mm), e.g. distance from the
// table at 8 points over X380 x Y380 mm ([PM-600 report] §2.4 fig. 2.4(a): 186 / 194 um
// conventional, 20 um with the jig).
//
//   range_um             = max z - min z: the raw readings relative to the datum, no plane removed
//                          (how [PM-600 report] fig. 2.4 states it, relative to one reference
//                          point)
//   flatness_lsq_um      = max - min of z_i - (c + a x_i + b y_i), least-squares plane
//   flatness_min_zone_um = smallest z-distance between two parallel planes enclosing all points
//                          (exact LP, analysis/geometry/plane_fit.h)
//   plane                = least-squares plane: slopes in um/m (1000 x um/mm), offset at x = y = 0
#pragma once

#include <string>

#include "analysis/form/profile.h"

namespace km::form {

struct PlaneReport {
  double slope_x_um_per_m = 0.0;
  double slope_y_um_per_m = 0.0;
  double offset_um = 0.0;  // plane value at x = y = 0
};

struct FlatnessResult {
  std::size_t points = 0;
  double flatness_lsq_um = 0.0;
  double flatness_min_zone_um = 0.0;
  double range_um = 0.0;
  PlaneReport plane;                              // least-squares plane
  PlaneReport min_zone_plane;                     // centre plane of the minimum zone
  std::string reference = "least_squares_plane";  // what `plane` is
  std::string range_reference = "datum";          // range_um: raw readings, nothing removed
};

// Throws InvalidInput for mismatched sizes / non-finite values, NotObservable when fewer than
// 3 points or the (x, y) positions are collinear.
FlatnessResult AnalyzeFlatness(const Grid& grid);

}  // namespace km::form
