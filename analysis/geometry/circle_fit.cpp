#include "analysis/geometry/circle_fit.h"

#include <cmath>
#include <optional>

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

// The points relative to m.
Coordinates Split(const std::vector<Eigen::Vector2d>& p, const Eigen::Vector2d& m) {
  Coordinates xy{Eigen::ArrayXd(static_cast<Eigen::Index>(p.size())),
                 Eigen::ArrayXd(static_cast<Eigen::Index>(p.size()))};
  for (std::size_t i = 0; i < p.size(); ++i) {
    xy.x[static_cast<Eigen::Index>(i)] = p[i].x() - m.x();
    xy.y[static_cast<Eigen::Index>(i)] = p[i].y() - m.y();
  }
  return xy;
}

// |p_i − c| (as (p_i − c).norm(): the square root of x² + y²).
Eigen::ArrayXd Distances(const Coordinates& xy, const Eigen::Vector2d& c) {
  return ((xy.x - c.x()).square() + (xy.y - c.y()).square()).sqrt();
}

// Σ (|p_i − c| − r)².
double SumSquares(const Coordinates& xy, const Eigen::Vector2d& c, double r) {
  return (Distances(xy, c) - r).square().sum();
}

}  // namespace

CircleNormalEquations CircleGaussNewton(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y,
                                        const Eigen::Vector2d& c, double r) {
  const Eigen::ArrayXd vx = x - c.x(), vy = y - c.y();
  const Eigen::ArrayXd dist = (vx.square() + vy.square()).sqrt();
  const Eigen::ArrayXd inv = (dist > 0.0).select(dist.inverse(), 0.0);
  const Eigen::ArrayXd ux = vx * inv, uy = vy * inv;
  const Eigen::ArrayXd d = (dist > 0.0).select(dist - r, 0.0);
  const double n = (dist > 0.0).count();
  CircleNormalEquations ne;
  const double sxx = ux.square().sum(), sxy = (ux * uy).sum(), syy = uy.square().sum();
  const double sx = ux.sum(), sy = uy.sum();
  ne.jtj << sxx, sxy, sx, sxy, syy, sy, sx, sy, n;
  ne.jtd << -(ux * d).sum(), -(uy * d).sum(), -d.sum();
  return ne;
}

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

namespace {

// The algebraic (Kåsa) fit of points given relative to their mean, from its 3 × 3 normal
// equations (a packet at a time); none when they are not clearly well conditioned (the caller
// then takes FitCircleAlgebraic, which decides and reports degenerate points).
std::optional<Circle> KasaStart(const Coordinates& xy) {
  const Eigen::ArrayXd r2 = xy.x.square() + xy.y.square();
  const double scale = std::sqrt(r2.maxCoeff());
  if (!(scale > 0.0) || !std::isfinite(scale)) return std::nullopt;
  const Eigen::ArrayXd x = xy.x / scale, y = xy.y / scale, z = -r2 / (scale * scale);
  const double sx = x.sum(), sy = y.sum(), n = static_cast<double>(x.size());
  const double sxy = (x * y).sum();
  Eigen::Matrix3d a;
  a << x.square().sum(), sxy, sx, sxy, y.square().sum(), sy, sx, sy, n;
  const Eigen::Vector3d b((x * z).sum(), (y * z).sum(), z.sum());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(a, Eigen::EigenvaluesOnly);
  if (!(eig.eigenvalues()[0] > 1e-12 * eig.eigenvalues()[2])) return std::nullopt;
  const Eigen::Vector3d def = a.ldlt().solve(b);
  const Eigen::Vector2d c(-def(0) / 2.0, -def(1) / 2.0);
  const double rr = c.squaredNorm() - def(2);
  if (!(rr > 0.0) || !std::isfinite(rr)) return std::nullopt;
  return Circle{c * scale, std::sqrt(rr) * scale};
}

}  // namespace

CircleFitResult FitCircleLeastSquares(const std::vector<Eigen::Vector2d>& points) {
  const Eigen::Vector2d m = points.size() >= 3 ? Mean(points) : Eigen::Vector2d::Zero();
  // Work in coordinates relative to the mean for precision.
  const Coordinates xy = Split(points, m);
  std::optional<Circle> start = points.size() >= 3 ? KasaStart(xy) : std::nullopt;
  if (!start) {
    start = FitCircleAlgebraic(points);
    start->centre -= m;
  }
  Eigen::Vector2d c = start->centre;
  double r = start->radius;
  double cost = SumSquares(xy, c, r);
  double lambda = 1e-6;
  CircleFitResult out;
  const double tol = 1e-15 * std::max(1.0, r);
  for (int it = 1; it <= 200; ++it) {
    out.iterations = it;
    const CircleNormalEquations ne = CircleGaussNewton(xy.x, xy.y, c, r);
    const Eigen::Matrix3d& jtj = ne.jtj;
    const Eigen::Vector3d& jtd = ne.jtd;
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
  out.rms_residual = std::sqrt(cost / static_cast<double>(points.size()));
  return out;
}

std::vector<double> CircleResiduals(const std::vector<Eigen::Vector2d>& points, const Circle& c) {
  std::vector<double> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = (points[i] - c.centre).norm() - c.radius;
  return out;
}

}  // namespace km::geometry
