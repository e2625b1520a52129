#include "analysis/geometry/circle_fit.h"

#include <cmath>

#include <Eigen/Dense>

#include "analysis/core/errors.h"

namespace km::geometry {
namespace {

Eigen::Vector2d Mean(const std::vector<Eigen::Vector2d>& p) {
  Eigen::Vector2d m = Eigen::Vector2d::Zero();
  for (const auto& q : p) m += q;
  return m / static_cast<double>(p.size());
}

// The points by coordinate, so the distances to a centre are computed a packet at a time.
struct Coordinates {
  Eigen::ArrayXd x, y;
};

Coordinates Split(const std::vector<Eigen::Vector2d>& p) {
  Coordinates xy{Eigen::ArrayXd(static_cast<Eigen::Index>(p.size())),
                 Eigen::ArrayXd(static_cast<Eigen::Index>(p.size()))};
  for (std::size_t i = 0; i < p.size(); ++i) {
    xy.x[static_cast<Eigen::Index>(i)] = p[i].x();
    xy.y[static_cast<Eigen::Index>(i)] = p[i].y();
  }
  return xy;
}

// |p_i − c| (as (p_i − c).norm(): the square root of x² + y²).
Eigen::ArrayXd Distances(const Coordinates& xy, const Eigen::Vector2d& c) {
  return ((xy.x - c.x()).square() + (xy.y - c.y()).square()).sqrt();
}

// Σ (|p_i − c| − r)², summed in point order.
double SumSquares(const Coordinates& xy, const Eigen::Vector2d& c, double r) {
  const Eigen::ArrayXd dist = Distances(xy, c);
  double s = 0.0;
  for (Eigen::Index i = 0; i < dist.size(); ++i) {
    const double d = dist[i] - r;
    s += d * d;
  }
  return s;
}

}  // namespace

Circle FitCircleAlgebraic(const std::vector<Eigen::Vector2d>& points) {
  if (points.size() < 3) throw InvalidInput("a circle fit needs at least 3 points");
  const Eigen::Vector2d m = Mean(points);
  const Eigen::Index n = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  double scale = 0.0;
  for (const auto& q : points) scale = std::max(scale, (q - m).norm());
  if (!(scale > 0.0)) throw InvalidInput("all points coincide; no circle can be fitted");
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector2d q = (points[static_cast<std::size_t>(i)] - m) / scale;
    a(i, 0) = q.x();
    a(i, 1) = q.y();
    a(i, 2) = 1.0;
    b(i) = -(q.squaredNorm());
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 3) throw InvalidInput("the points are collinear; no circle can be fitted");
  const Eigen::Vector3d def = qr.solve(b);
  const Eigen::Vector2d c(-def(0) / 2.0, -def(1) / 2.0);
  const double r2 = c.squaredNorm() - def(2);
  if (!(r2 > 0.0) || !std::isfinite(r2)) {
    throw InvalidInput("the points do not describe a circle");
  }
  return Circle{m + c * scale, std::sqrt(r2) * scale};
}

CircleFitResult FitCircleLeastSquares(const std::vector<Eigen::Vector2d>& points) {
  const Circle start = FitCircleAlgebraic(points);
  const Eigen::Vector2d m = Mean(points);
  // Work in coordinates relative to the mean for precision.
  std::vector<Eigen::Vector2d> p(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) p[i] = points[i] - m;
  Eigen::Vector2d c = start.centre - m;
  double r = start.radius;
  const Coordinates xy = Split(p);
  double cost = SumSquares(xy, c, r);
  double lambda = 1e-6;
  CircleFitResult out;
  const double tol = 1e-15 * std::max(1.0, r);
  for (int it = 1; it <= 200; ++it) {
    out.iterations = it;
    // Normal equations of the residual d_i = |p_i − c| − r; J row = [−u_x, −u_y, −1].
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Eigen::Vector3d jtd = Eigen::Vector3d::Zero();
    const Eigen::ArrayXd dist = Distances(xy, c);
    for (std::size_t i = 0; i < p.size(); ++i) {
      const Eigen::Vector2d v = p[i] - c;
      const double di = dist[static_cast<Eigen::Index>(i)];
      if (!(di > 0.0)) continue;
      const Eigen::Vector3d j(-v.x() / di, -v.y() / di, -1.0);
      const double d = di - r;
      jtj += j * j.transpose();
      jtd += j * d;
    }
    bool accepted = false;
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    for (int k = 0; k < 30 && !accepted; ++k) {
      Eigen::Matrix3d a = jtj;
      a.diagonal() += lambda * jtj.diagonal().cwiseMax(1e-300);
      step = -a.ldlt().solve(jtd);
      // A step below the tolerance cannot lower the cost beyond rounding: converged.
      if (step.norm() <= tol) break;
      const Eigen::Vector2d c_new = c + step.head<2>();
      const double r_new = r + step(2);
      const double cost_new = SumSquares(xy, c_new, r_new);
      if (std::isfinite(cost_new) && cost_new <= cost) {
        c = c_new;
        r = r_new;
        cost = cost_new;
        lambda = std::max(lambda * 0.1, 1e-12);
        accepted = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!accepted || step.norm() <= tol) {
      // No further decrease possible: the minimum is reached to machine precision.
      out.converged = true;
      break;
    }
  }
  if (!out.converged) {
    throw DidNotConverge("least-squares circle fit did not converge in 200 iterations");
  }
  out.circle = Circle{c + m, r};
  out.rms_residual = std::sqrt(cost / static_cast<double>(p.size()));
  return out;
}

std::vector<double> CircleResiduals(const std::vector<Eigen::Vector2d>& points, const Circle& c) {
  std::vector<double> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = (points[i] - c.centre).norm() - c.radius;
  return out;
}

}  // namespace km::geometry
