// Parallelism of an axis to a datum (e.g. the T-slot, [PM-600 report] §2.4 fig. 2.4(b): 78 / 71 um
// conventional, 19 um with the jig over X380 mm): the distance d(x) from the datum read while
// the axis travels.
//
//   parallelism_um = max d - min d over the travel (full reading range, nothing removed: the
//                    datum itself is the reference)
//   slope_um_per_m = 1000 x slope of the least-squares line through d(x)
//   length_mm      = last position - first position
#pragma once

#include <string>

#include "analysis/form/profile.h"

namespace km::form {

struct ParallelismResult {
  std::size_t points = 0;
  double parallelism_um = 0.0;
  double slope_um_per_m = 0.0;
  double length_mm = 0.0;
  double straightness_lsq_um = 0.0;  // residual P-V about the least-squares line (extra)
  std::string reference = "datum";   // parallelism_um
  std::string slope_reference = "least_squares_line";
};

// Throws InvalidInput for a malformed profile, NotObservable for fewer than 2 points.
ParallelismResult AnalyzeParallelism(const Profile& profile);

}  // namespace km::form
