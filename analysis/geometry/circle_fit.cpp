#include "analysis/geometry/circle_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Dense>

#include "analysis/core/errors.h"
#include "analysis/geometry/circle_sums.h"

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

// Σ (|p_i − c| − r)², as CircleGaussNewton sums it.
double SumSquares(const Coordinates& xy, const Eigen::Vector2d& c, double r) {
  double fused = 0.0;
  if (internal::CircleCostFused(xy.x.data(), xy.y.data(), xy.x.size(), c.x(), c.y(), r, fused))
    return fused;
  constexpr Eigen::Index kBlock = 256;
  using Block = Eigen::Array<double, Eigen::Dynamic, 1, 0, kBlock, 1>;
  double ss = 0.0;
  for (Eigen::Index i0 = 0; i0 < xy.x.size(); i0 += kBlock) {
    const Eigen::Index len = std::min(kBlock, xy.x.size() - i0);
    const Block vx = xy.x.segment(i0, len) - c.x(), vy = xy.y.segment(i0, len) - c.y();
    ss += ((vx.square() + vy.square()).sqrt() - r).square().sum();
  }
  return ss;
}

// Rounding of the cost Σ d_i² (d_i = |p_i − c| − r): each distance is rounded to about ε·r,
// which moves the cost by up to 2ε·r·Σ|d_i| ≤ 2ε·r·√(N·cost), and the sum of N terms adds up to
// N·ε·cost. A change of the cost below this cannot be told from its rounding.
double CostRounding(double cost, double r, std::size_t n) {
  const double eps = std::numeric_limits<double>::epsilon(), nn = static_cast<double>(n);
  return eps * (nn * cost + 2.0 * std::abs(r) * std::sqrt(nn * cost));
}

}  // namespace

CircleNormalEquations CircleGaussNewton(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y,
                                        const Eigen::Vector2d& c, double r) {
  CircleNormalEquations ne;
  internal::CircleSums f;
  if (internal::CircleSumsFused(x.data(), y.data(), x.size(), c.x(), c.y(), r, f)) {
    ne.jtj << f.sxx, f.sxy, f.sx, f.sxy, f.syy, f.sy, f.sx, f.sy, f.n;
    ne.jtd << f.bx, f.by, f.b;
    ne.sum_squares = f.ss;
    return ne;
  }
  // Blocks of points held in arrays on the stack: one pass over the points, a packet at a time.
  constexpr Eigen::Index kBlock = 256;
  using Block = Eigen::Array<double, Eigen::Dynamic, 1, 0, kBlock, 1>;
  double sxx = 0, sxy = 0, syy = 0, sx = 0, sy = 0, n = 0, bx = 0, by = 0, b = 0, ss = 0;
  for (Eigen::Index i0 = 0; i0 < x.size(); i0 += kBlock) {
    const Eigen::Index len = std::min(kBlock, x.size() - i0);
    const Block vx = x.segment(i0, len) - c.x(), vy = y.segment(i0, len) - c.y();
    const Block dist = (vx.square() + vy.square()).sqrt();
    const Block inv = (dist > 0.0).select(dist.inverse(), 0.0);
    const Block ux = vx * inv, uy = vy * inv;
    const Block all = dist - r;
    const Block d = (dist > 0.0).select(all, 0.0);
    sxx += ux.square().sum();
    sxy += (ux * uy).sum();
    syy += uy.square().sum();
    sx += ux.sum();
    sy += uy.sum();
    n += static_cast<double>((dist > 0.0).count());
    bx -= (ux * d).sum();
    by -= (uy * d).sum();
    b -= d.sum();
    ss += all.square().sum();
  }
  ne.jtj << sxx, sxy, sx, sxy, syy, sy, sx, sy, n;
  ne.jtd << bx, by, b;
  ne.sum_squares = ss;
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
// equations (summed in one pass); none when they are not clearly well conditioned (the caller
// then takes FitCircleAlgebraic, which decides and reports degenerate points).
std::optional<Circle> KasaStart(const Coordinates& xy) {
  const Eigen::Index m = xy.x.size();
  double r2max = 0.0;
  for (Eigen::Index i = 0; i < m; ++i)
    r2max = std::max(r2max, xy.x[i] * xy.x[i] + xy.y[i] * xy.y[i]);
  const double scale = std::sqrt(r2max);
  if (!(scale > 0.0) || !std::isfinite(scale)) return std::nullopt;
  // The sums of the scaled coordinates in one pass (no arrays of the points' length); the start
  // only has to be close: the Gauss–Newton steps below reach the minimum.
  const double inv = 1.0 / scale;
  double sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0, sxz = 0, syz = 0, sz = 0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const double x = xy.x[i] * inv, y = xy.y[i] * inv, z = -(x * x + y * y);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
    syy += y * y;
    sxz += x * z;
    syz += y * z;
    sz += z;
  }
  Eigen::Matrix3d a;
  a << sxx, sxy, sx, sxy, syy, sy, sx, sy, static_cast<double>(m);
  const Eigen::Vector3d b(sxz, syz, sz);
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
  // The normal equations come with the cost at their point (one pass for both); a point tried
  // costs a pass for its cost only (tries that fail are common near the minimum).
  CircleNormalEquations ne = CircleGaussNewton(xy.x, xy.y, c, r);
  double cost = ne.sum_squares;
  double lambda = 1e-6;
  CircleFitResult out;
  const double tol = 1e-15 * std::max(1.0, r);
  for (int it = 1; it <= 200; ++it) {
    out.iterations = it;
    const Eigen::Matrix3d jtj = ne.jtj;
    const Eigen::Vector3d jtd = ne.jtd;
    // Near the minimum the Gauss–Newton step predicts a decrease below the cost's rounding: the
    // quadratic model is then exact to rounding, and trying the step on the cost would only
    // compare rounding errors. The step is taken, and the minimum is reached.
    // The cost there must not exceed the present one beyond its rounding (else the model does
    // not hold so far out, e.g. along the flat valley of a short arc: the trials below decide).
    const double noise = CostRounding(cost, r, points.size());
    const Eigen::Vector3d gn = -jtj.ldlt().solve(jtd);
    if (gn.allFinite() && -0.5 * gn.dot(jtd) <= noise) {
      const Eigen::Vector2d c_gn = c + gn.head<2>();
      const double r_gn = r + gn(2);
      const double cost_gn = SumSquares(xy, c_gn, r_gn);
      if (cost_gn <= cost + noise) {
        c = c_gn;
        r = r_gn;
        cost = cost_gn;
        out.converged = true;
        break;
      }
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
        ne = CircleGaussNewton(xy.x, xy.y, c_new, r_new);
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
