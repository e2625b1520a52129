// Planar convex hull by Andrew's monotone chain.
//
// Points p_i = (x_i, y_i) are sorted by x (then y); the lower chain keeps the points where the
// path turns counter-clockwise (cross product > 0), the upper chain those where it turns
// clockwise. Collinear points are dropped, so consecutive edge slopes of the upper chain
// strictly decrease and those of the lower chain strictly increase. O(n log n), or O(n) when
// the input is already sorted by x (as a measured profile is).
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace km::geometry {

struct MonotoneHull {
  // Indices into the input, both chains from the smallest to the largest x. They share their
  // first and last point.
  std::vector<std::size_t> lower;
  std::vector<std::size_t> upper;
};

// Lower and upper chains of the convex hull of (x_i, y_i). x and y must have the same size.
MonotoneHull ConvexHullChains(std::span<const double> x, std::span<const double> y);

// Closed hull polygon in counter-clockwise order (first point not repeated).
std::vector<std::size_t> ConvexHull2D(std::span<const double> x, std::span<const double> y);

}  // namespace km::geometry
