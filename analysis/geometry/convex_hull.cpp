#include "analysis/geometry/convex_hull.h"

#include <algorithm>
#include <numeric>

#include "analysis/core/errors.h"

namespace km::geometry {
namespace {

double Cross(std::span<const double> x, std::span<const double> y, std::size_t o, std::size_t a,
             std::size_t b) {
  return (x[a] - x[o]) * (y[b] - y[o]) - (y[a] - y[o]) * (x[b] - x[o]);
}

}  // namespace

MonotoneHull ConvexHullChains(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size()) throw InvalidInput("convex hull: x and y differ in size");
  MonotoneHull h;
  if (x.empty()) return h;
  std::vector<std::size_t> order(x.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const auto less = [&](std::size_t a, std::size_t b) {
    return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]);
  };
  if (!std::is_sorted(order.begin(), order.end(), less)) {
    std::sort(order.begin(), order.end(), less);
  }
  for (std::size_t i : order) {
    while (h.lower.size() >= 2 &&
           Cross(x, y, h.lower[h.lower.size() - 2], h.lower.back(), i) <= 0.0) {
      h.lower.pop_back();
    }
    h.lower.push_back(i);
  }
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    const std::size_t i = *it;
    while (h.upper.size() >= 2 &&
           Cross(x, y, h.upper[h.upper.size() - 2], h.upper.back(), i) <= 0.0) {
      h.upper.pop_back();
    }
    h.upper.push_back(i);
  }
  std::reverse(h.upper.begin(), h.upper.end());
  return h;
}

std::vector<std::size_t> ConvexHull2D(std::span<const double> x, std::span<const double> y) {
  const MonotoneHull h = ConvexHullChains(x, y);
  std::vector<std::size_t> out = h.lower;
  if (h.upper.size() > 2) {
    // Upper chain from right to left without its end points.
    for (std::size_t k = h.upper.size() - 2; k >= 1; --k) out.push_back(h.upper[k]);
  }
  if (out.size() == 2 && out[0] == out[1]) out.pop_back();
  return out;
}

}  // namespace km::geometry
