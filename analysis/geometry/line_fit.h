// Reference lines for a profile y(x) sampled at points (x_i, y_i), with deviations measured
// in the y direction (the usual straightness convention: x = position along the travel, y =
// deviation perpendicular to it, the angle between line and travel being tiny).
//
//   least squares:  min over (m, c) of  sum_i (y_i - c - m x_i)^2         (closed form)
//   end points:     the line through the points with the smallest and largest x
//   minimum zone:   min over m of  W(m) = max_i (y_i - m x_i) - min_i (y_i - m x_i)
//
// W(m) is convex and piecewise linear; its breakpoints are the slopes of the edges of the
// convex hull of the points. For a slope m the maximum of y - m x is attained at the vertex of
// the upper hull chain whose neighbouring edge slopes bracket m, the minimum at such a vertex of
// the lower chain (rotating calipers on the two chains). The minimum-zone line is therefore
// exact: W is evaluated at every hull-edge slope and the smallest value is taken
// (O(n log n), dominated by the hull).
#pragma once

#include <span>

namespace km::geometry {

// y = intercept + slope * x.
struct Line2 {
  double slope = 0.0;
  double intercept = 0.0;
  double operator()(double x) const { return intercept + slope * x; }
};

// Two parallel lines of equal slope enclosing every point with the smallest vertical gap.
struct MinimumZoneLine {
  Line2 centre;        // the line half-way between the two enclosing lines
  double width = 0.0;  // vertical distance between them (same unit as y)
};

// Least-squares line. Throws NotObservable when fewer than two distinct x are given,
// InvalidInput when sizes differ.
Line2 FitLineLeastSquares(std::span<const double> x, std::span<const double> y);

// The line through the points with the smallest and the largest x (first and last point of a
// profile sorted by position). Throws NotObservable when all x are equal.
Line2 LineThroughEndPoints(std::span<const double> x, std::span<const double> y);

// Exact minimum-zone line (vertical width). Throws NotObservable when all x are equal.
MinimumZoneLine FitLineMinimumZone(std::span<const double> x, std::span<const double> y);

// max_i r_i - min_i r_i with r_i = y_i - line(x_i). 0 for an empty input.
double PeakToValley(std::span<const double> x, std::span<const double> y, const Line2& line);

}  // namespace km::geometry
