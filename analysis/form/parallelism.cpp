#include "analysis/form/parallelism.h"

#include <algorithm>

#include "analysis/core/errors.h"
#include "analysis/form/straightness.h"
#include "analysis/geometry/line_fit.h"

namespace km::form {

ParallelismResult AnalyzeParallelism(const Profile& profile) {
  CheckProfile(profile, 2);
  const auto& x = profile.position_mm;
  const auto& d = profile.deviation_um;
  ParallelismResult r;
  r.points = x.size();
  const auto [dmin, dmax] = std::minmax_element(d.begin(), d.end());
  r.parallelism_um = *dmax - *dmin;
  r.length_mm = x.back() - x.front();
  const geometry::Line2 lsq = geometry::FitLineLeastSquares(x, d);
  r.slope_um_per_m = 1000.0 * lsq.slope;
  r.straightness_lsq_um = geometry::PeakToValley(x, d, lsq);
  return r;
}

}  // namespace km::form
