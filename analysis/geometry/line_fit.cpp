#include "analysis/geometry/line_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/geometry/convex_hull.h"

namespace km::geometry {
namespace {

void CheckSizes(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size()) throw InvalidInput("line fit: x and y differ in size");
  if (x.size() < 2) throw NotObservable("line fit: at least two points are needed");
}

double Mean(std::span<const double> v) {
  double s = 0.0;
  for (double e : v) s += e;
  return s / static_cast<double>(v.size());
}

}  // namespace

Line2 FitLineLeastSquares(std::span<const double> x, std::span<const double> y) {
  CheckSizes(x, y);
  // Centred sums keep the normal equations well conditioned for positions far from 0.
  const double mx = Mean(x);
  const double my = Mean(y);
  double sxx = 0.0, sxy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double dx = x[i] - mx;
    sxx += dx * dx;
    sxy += dx * (y[i] - my);
  }
  if (!(sxx > 0.0)) throw NotObservable("line fit: all points have the same position");
  Line2 l;
  l.slope = sxy / sxx;
  l.intercept = my - l.slope * mx;
  return l;
}

Line2 LineThroughEndPoints(std::span<const double> x, std::span<const double> y) {
  CheckSizes(x, y);
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  const std::size_t i0 = static_cast<std::size_t>(lo - x.begin());
  const std::size_t i1 = static_cast<std::size_t>(hi - x.begin());
  if (!(x[i1] > x[i0])) throw NotObservable("line fit: all points have the same position");
  Line2 l;
  l.slope = (y[i1] - y[i0]) / (x[i1] - x[i0]);
  l.intercept = y[i0] - l.slope * x[i0];
  return l;
}

MinimumZoneLine FitLineMinimumZone(std::span<const double> x, std::span<const double> y) {
  CheckSizes(x, y);
  const double mx = Mean(x);
  std::vector<double> xc(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) xc[i] = x[i] - mx;
  const MonotoneHull hull = ConvexHullChains(xc, y);
  const auto& up = hull.upper;
  const auto& lo = hull.lower;
  if (!(xc[up.back()] > xc[up.front()])) {
    throw NotObservable("line fit: all points have the same position");
  }
  // Edge slopes: decreasing along the upper chain, increasing along the lower chain.
  std::vector<double> s_up, s_lo;
  for (std::size_t k = 1; k < up.size(); ++k) {
    s_up.push_back((y[up[k]] - y[up[k - 1]]) / (xc[up[k]] - xc[up[k - 1]]));
  }
  for (std::size_t k = 1; k < lo.size(); ++k) {
    s_lo.push_back((y[lo[k]] - y[lo[k - 1]]) / (xc[lo[k]] - xc[lo[k - 1]]));
  }
  // Width at slope m from the supporting vertices: upper vertex j has s_up[j-1] >= m >=
  // s_up[j]; lower vertex k has s_lo[k-1] <= m <= s_lo[k].
  const auto width_at = [&](double m) {
    const std::size_t j = static_cast<std::size_t>(
        std::upper_bound(s_up.begin(), s_up.end(), m, std::greater<double>()) - s_up.begin());
    const std::size_t k =
        static_cast<std::size_t>(std::lower_bound(s_lo.begin(), s_lo.end(), m) - s_lo.begin());
    const std::size_t iu = up[std::min(j, up.size() - 1)];
    const std::size_t il = lo[std::min(k, lo.size() - 1)];
    return (y[iu] - m * xc[iu]) - (y[il] - m * xc[il]);
  };
  double best_m = 0.0;
  double best_w = std::numeric_limits<double>::infinity();
  for (const auto* slopes : {&s_up, &s_lo}) {
    for (double m : *slopes) {
      if (!std::isfinite(m)) continue;  // vertical hull edge (repeated position)
      const double w = width_at(m);
      if (w < best_w) {
        best_w = w;
        best_m = m;
      }
    }
  }
  // The zone from all points at the chosen slope (also covers rounding in the hull).
  double hi = -std::numeric_limits<double>::infinity();
  double lw = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = y[i] - best_m * xc[i];
    hi = std::max(hi, r);
    lw = std::min(lw, r);
  }
  MinimumZoneLine z;
  z.centre.slope = best_m;
  z.centre.intercept = 0.5 * (hi + lw) - best_m * mx;
  z.width = hi - lw;
  return z;
}

double PeakToValley(std::span<const double> x, std::span<const double> y, const Line2& line) {
  if (x.size() != y.size()) throw InvalidInput("peak to valley: x and y differ in size");
  if (x.empty()) return 0.0;
  double hi = -std::numeric_limits<double>::infinity();
  double lw = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = y[i] - line(x[i]);
    hi = std::max(hi, r);
    lw = std::min(lw, r);
  }
  return hi - lw;
}

}  // namespace km::geometry
