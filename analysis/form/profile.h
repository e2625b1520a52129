// Measured form data shared by the form analyses and the ingest parsers.
//   Profile: deviation_um(position_mm) along a travel (straightness, parallelism).
//   Grid:    z_um(x_mm, y_mm) over a surface (flatness).
// Positions in mm, deviations in um (docs/formats.md §1.3-1.5).
#pragma once

#include <vector>

namespace km::form {

struct Profile {
  std::vector<double> position_mm;  // strictly increasing
  std::vector<double> deviation_um;
};

struct Grid {
  std::vector<double> x_mm;
  std::vector<double> y_mm;
  std::vector<double> z_um;
};

}  // namespace km::form
