// The sums of one Gauss–Newton step of the orthogonal least-squares circle (circle_fit.h
// CircleGaussNewton) and its cost Σ (|p_i − c| − r)², four points at a time with AVX2 and fused
// multiply-adds in a single pass. The sums round differently from the Eigen expression they stand
// in for (lanes, fused products): a fit's figures move by its rounding, not by its tolerance.
// Both functions sum the same way, so a point's cost is the same whichever one priced it.
// Internal to analysis/geometry.
#pragma once

#include <Eigen/Core>

namespace km::geometry::internal {

struct CircleSums {
  double sxx = 0, sxy = 0, syy = 0, sx = 0, sy = 0, n = 0, bx = 0, by = 0, b = 0, ss = 0;
};

// Fill `out` (or `cost`) for the points (x, y) and the circle (cx, cy, r); false, and nothing
// computed, when the processor lacks AVX2 and FMA (the caller then sums with Eigen).
bool CircleSumsFused(const double* x, const double* y, Eigen::Index n, double cx, double cy,
                     double r, CircleSums& out);
bool CircleCostFused(const double* x, const double* y, Eigen::Index n, double cx, double cy,
                     double r, double& cost);

}  // namespace km::geometry::internal
