// Least-squares circle fit ([PM-600 report] eq. 2.6 / 4.6):
//
//   min over (x0, y0, r0) of  Σ_n ( sqrt((x_n − x0)² + (y_n − y0)²) − r0 )²
//
// solved by Levenberg–Marquardt on the geometric (orthogonal-distance) residuals, started from
// the algebraic (Kåsa) fit  x² + y² + D x + E y + F = 0, which is linear in (D, E, F).
// Coordinates are shifted to their mean before solving, so traces far from the origin keep full
// precision. Units are whatever the caller uses (kinemetric passes µm).
#pragma once

#include <vector>

#include <Eigen/Core>

namespace km::geometry {

struct Circle {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius = 0.0;
};

struct CircleFitResult {
  Circle circle;
  double rms_residual = 0.0;  // sqrt(mean of squared orthogonal residuals)
  int iterations = 0;
  bool converged = false;
};

// Algebraic fit (Kåsa). Needs ≥ 3 points not all on one line; throws km::InvalidInput otherwise.
Circle FitCircleAlgebraic(const std::vector<Eigen::Vector2d>& points);

// Geometric least-squares fit. Throws km::InvalidInput for < 3 points or collinear points,
// km::DidNotConverge when the iteration fails to reach the tolerance.
CircleFitResult FitCircleLeastSquares(const std::vector<Eigen::Vector2d>& points);

// Normal equations of one Gauss–Newton step of the orthogonal-distance fit, for points given
// by coordinates x, y: residual d_i = |p_i − c| − r, jacobian row [−u_x, −u_y, −1] (u the unit
// vector from c to p_i; points at c left out), and the cost Σ d_i² over all points. Computed in
// one pass, a packet at a time (the sums in any order: they agree with point-order sums to
// rounding).
struct CircleNormalEquations {
  Eigen::Matrix3d jtj;
  Eigen::Vector3d jtd;
  double sum_squares = 0.0;
};
CircleNormalEquations CircleGaussNewton(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y,
                                        const Eigen::Vector2d& c, double r);

// Orthogonal residuals |p − c| − r of each point.
std::vector<double> CircleResiduals(const std::vector<Eigen::Vector2d>& points, const Circle& c);

}  // namespace km::geometry
