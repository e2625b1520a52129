// Reference planes for a surface z(x, y) sampled at points (x_i, y_i, z_i), with deviations
// measured in the z direction (flatness convention: z = reading perpendicular to the surface,
// the angle between plane and datum being tiny).
//
//   least squares:  min over (a, b, c) of  sum_i (z_i - c - a x_i - b y_i)^2   (closed form)
//   minimum zone:   min over (a, b) of  W(a, b) = max_i r_i - min_i r_i,  r_i = z_i - a x_i - b y_i
//
// The minimum zone is the linear programme  min u + v  s.t.  u >= r_i(a, b),  v >= -r_i(a, b).
// It is solved exactly through its dual, which has only four equality rows:
//
//   max  sum_i (lambda_i - mu_i) z_i   s.t.  sum lambda = 1,  sum mu = 1,
//        sum (lambda_i - mu_i) x_i = 0,  sum (lambda_i - mu_i) y_i = 0,  lambda, mu >= 0,
//
// i.e. the largest vertical thickness of the convex hull of the points. A revised simplex with
// a 4x4 basis pivots on it; at the optimum the simplex multipliers of the last two rows are the
// slopes (a, b) of the two enclosing planes. Each pivot costs O(n); the result is exact up to
// floating-point rounding (no grid search). Inputs are centred and scaled first.
#pragma once

#include <span>

namespace km::geometry {

// z = offset + slope_x * x + slope_y * y.
struct Plane3 {
  double slope_x = 0.0;
  double slope_y = 0.0;
  double offset = 0.0;
  double operator()(double x, double y) const { return offset + slope_x * x + slope_y * y; }
};

struct MinimumZonePlane {
  Plane3 centre;       // half-way between the two enclosing planes
  double width = 0.0;  // their distance along z (same unit as z)
  int iterations = 0;  // simplex pivots used
};

// Least-squares plane. Throws NotObservable when the (x, y) positions are collinear,
// InvalidInput when sizes differ.
Plane3 FitPlaneLeastSquares(std::span<const double> x, std::span<const double> y,
                            std::span<const double> z);

// Exact minimum-zone plane (width along z). Throws NotObservable when the (x, y) positions
// are collinear, DidNotConverge if the simplex exceeds its pivot limit.
MinimumZonePlane FitPlaneMinimumZone(std::span<const double> x, std::span<const double> y,
                                     std::span<const double> z);

// max_i r_i - min_i r_i with r_i = z_i - plane(x_i, y_i). 0 for an empty input.
double PeakToValley(std::span<const double> x, std::span<const double> y, std::span<const double> z,
                    const Plane3& plane);

}  // namespace km::geometry
