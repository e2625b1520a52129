#include "analysis/geometry/circle_fit_radial.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/geometry/circle_fit.h"

namespace km::geometry {
namespace {

// The largest curvature term a linearised fit may leave out of a residual (µm); above it the
// fit is done in full.
constexpr double kLinearTolerance = 1e-7;

// The normal equations of one Gauss–Newton step of the orthogonal-distance circle fit
// (CircleGaussNewton's) in one pass without temporaries.
CircleNormalEquations RadialNormalEquations(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y,
                                            const Eigen::Vector3d& c) {
  double sxx = 0, sxy = 0, syy = 0, sx = 0, sy = 0, n = 0, bx = 0, by = 0, b = 0;
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    const double vx = x[k] - c[0], vy = y[k] - c[1];
    const double dist = std::sqrt(vx * vx + vy * vy);
    if (!(dist > 0.0)) continue;
    const double ux = vx / dist, uy = vy / dist, d = dist - c[2];
    sxx += ux * ux;
    sxy += ux * uy;
    syy += uy * uy;
    sx += ux;
    sy += uy;
    n += 1.0;
    bx -= ux * d;
    by -= uy * d;
    b -= d;
  }
  CircleNormalEquations ne;
  ne.jtj << sxx, sxy, sx, sxy, syy, sy, sx, sy, n;
  ne.jtd << bx, by, b;
  return ne;
}

}  // namespace

Eigen::Vector3d LeastSquaresCircleFrom(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y,
                                       Eigen::Vector3d c) {
  for (int it = 0; it < 30; ++it) {
    const CircleNormalEquations ne = RadialNormalEquations(x, y, c);
    const Eigen::Vector3d step = -ne.jtj.ldlt().solve(ne.jtd);
    c += step;
    if (step.norm() <= 1e-12 * c[2]) return c;
  }
  throw DidNotConverge("the least-squares circle did not converge");
}

void RadialCircleFit::Init(std::span<const double> x, std::span<const double> y,
                           std::span<const double> ex, std::span<const double> ey,
                           const Eigen::Vector3d& start) {
  const std::size_t n = x.size();
  const Eigen::ArrayXd ax =
      Eigen::Map<const Eigen::ArrayXd>(x.data(), static_cast<Eigen::Index>(n));
  const Eigen::ArrayXd ay =
      Eigen::Map<const Eigen::ArrayXd>(y.data(), static_cast<Eigen::Index>(n));
  c0_ = LeastSquaresCircleFrom(ax, ay, start);
  const CircleNormalEquations ne = RadialNormalEquations(ax, ay, c0_);
  jtj_inv_ = ne.jtj.inverse();
  x0_.assign(x.begin(), x.end());
  y0_.assign(y.begin(), y.end());
  ex_.assign(ex.begin(), ex.end());
  ey_.assign(ey.begin(), ey.end());
  for (auto* v : {&r0_, &ux_, &uy_, &a_, &b_}) v->resize(n);
  weights_.resize(static_cast<Eigen::Index>(n), 5);
  b_max_ = 0.0;
  moments_ = Moments{};
  Moments& m = moments_;
  for (std::size_t k = 0; k < n; ++k) {
    const double vx = x[k] - c0_[0], vy = y[k] - c0_[1];
    const double dist = std::sqrt(vx * vx + vy * vy);
    if (!(dist > 0.0)) throw InvalidInput("", 0, "points", "a point lies at the circle's centre");
    ux_[k] = vx / dist;
    uy_[k] = vy / dist;
    r0_[k] = dist - c0_[2];
    const double x1 = ux_[k], y1 = uy_[k], r = r0_[k];
    a_[k] = ex[k] * x1 + ey[k] * y1;
    b_[k] = ey[k] * x1 - ex[k] * y1;  // e·t, t = (−uy, ux)
    const auto i = static_cast<Eigen::Index>(k);
    weights_(i, 0) = a_[k] * x1;
    weights_(i, 1) = a_[k] * y1;
    weights_(i, 2) = a_[k];
    weights_(i, 3) = a_[k] * x1 * y1;
    weights_(i, 4) = a_[k] * y1 * y1;
    b_max_ = std::max(b_max_, std::abs(b_[k]));
    m.n += 1.0;
    m.x += x1;
    m.y += y1;
    m.xx += x1 * x1;
    m.xy += x1 * y1;
    m.yy += y1 * y1;
    m.xxx += x1 * x1 * x1;
    m.xxy += x1 * x1 * y1;
    m.xyy += x1 * y1 * y1;
    m.yyy += y1 * y1 * y1;
    m.r0 += r;
    m.r0x += x1 * r;
    m.r0y += y1 * r;
    m.r0xy += x1 * y1 * r;
    m.r0yy += y1 * y1 * r;
  }
}

RadialCircleFit::Result RadialCircleFit::Fit(std::span<const double> s, std::span<double> out) {
  const auto n = static_cast<Eigen::Index>(r0_.size());
  const Eigen::Map<const Eigen::VectorXd> sv(s.data(), n);
  // The pass over the moves: Σ w·a·s for the weights w = ux, uy, 1, ux·uy, uy² (the right
  // sides of both steps are polynomials in these and the base's moments).
  const Eigen::Matrix<double, 5, 1> p = weights_.transpose() * sv;
  // Σ w·d, d = r0 + a·s: the residuals about c0 to first order in s.
  const Moments& m = moments_;
  const double dx_sum = m.r0x + p[0], dy_sum = m.r0y + p[1], d_sum = m.r0 + p[2];
  const double dxy_sum = m.r0xy + p[3], dyy_sum = m.r0yy + p[4];
  // Step 1 with the base design.
  const Eigen::Vector3d d1 = jtj_inv_ * Eigen::Vector3d(dx_sum, dy_sum, d_sum);
  const double dx = d1[0], dy = d1[1], dr = d1[2];
  const double inv_r = 1.0 / c0_[2];
  // Step 2 at c0 + Δ1: the residuals there to second order in Δ1, e = d − u·Δ1 − Δr +
  // (t·Δ1)²/2R (t ⊥ u), and the design turned by the centre's move, u1 = u + (t·Δ1)(uy, −ux)/R.
  const double q2 = dy * dy * m.xx - 2.0 * dx * dy * m.xy + dx * dx * m.yy;     // Σ (t·Δ)²
  const double qx = dy * dy * m.xxx - 2.0 * dx * dy * m.xxy + dx * dx * m.xyy;  // Σ ux(t·Δ)²
  const double qy = dy * dy * m.xxy - 2.0 * dx * dy * m.xyy + dx * dx * m.yyy;  // Σ uy(t·Δ)²
  const double sx = dx_sum - dx * m.xx - dy * m.xy - dr * m.x + 0.5 * inv_r * qx;
  const double sy = dy_sum - dx * m.xy - dy * m.yy - dr * m.y + 0.5 * inv_r * qy;
  const double se = d_sum - dx * m.x - dy * m.y - dr * m.n + 0.5 * inv_r * q2;
  const double pxy = dxy_sum - dx * m.xxy - dy * m.xyy - dr * m.xy;          // Σ ux·uy·e
  const double pyy = dyy_sum - dx * m.xyy - dy * m.yyy - dr * m.yy;          // Σ uy²·e
  const double pxx = d_sum - dyy_sum - dx * m.xxx - dy * m.xxy - dr * m.xx;  // Σ ux²·e
  const double tx = dy * pxy - dx * pyy, ty = dy * pxx - dx * pxy;  // Σ (t·Δ)·(uy, ux)·e
  const Eigen::Vector3d d2 = jtj_inv_ * Eigen::Vector3d(sx + tx * inv_r, sy - ty * inv_r, se);
  const Eigen::Vector3d delta = d1 + d2;
  // The residuals about c0 + Δ: |w + s·e − Δ| to second order, w + s·e − Δ =
  // (|w| + a·s − u·Δ)·u + (b·s − t·Δ)·t, b = e·t.
  const double cx = delta[0], cy = delta[1], cr = delta[2], half_inv_r = 0.5 * inv_r;
  scratch_.resize(r0_.size());
  Eigen::Map<Eigen::ArrayXd> e(out.empty() ? scratch_.data() : out.data(), n);
  const auto sa = sv.array();
  const Eigen::Map<const Eigen::ArrayXd> r0(r0_.data(), n), ux(ux_.data(), n), uy(uy_.data(), n),
      a(a_.data(), n), b(b_.data(), n);
  e = r0 + a * sa - (ux * cx + uy * cy) - cr + (b * sa - (ux * cy - uy * cx)).square() * half_inv_r;
  const double lo = e.minCoeff(), hi = e.maxCoeff();
  const double smax = sa.abs().maxCoeff();
  // Left out (a bound): the turn of the design by the moves themselves, b·s/R, in both steps'
  // right sides (each point's weight off by at most max|b·s|/R, on residuals of at most
  // max|e|: the centre off by at most twice their product), and the third order of the
  // centre's move. Above the tolerance the fit is done in full.
  const double step = delta.head<2>().norm();
  const double neglected =
      2.0 * b_max_ * smax * inv_r * std::max(hi, -lo) + step * step * step * inv_r * inv_r;
  if (!(neglected <= kLinearTolerance)) return FitExact(s, out);
  return {c0_ + delta, lo, hi, false};
}

RadialCircleFit::Result RadialCircleFit::FitExact(std::span<const double> s,
                                                  std::span<double> out) const {
  const auto n = static_cast<Eigen::Index>(r0_.size());
  Eigen::ArrayXd x(n), y(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(k);
    x[k] = x0_[i] + s[i] * ex_[i];
    y[k] = y0_[i] + s[i] * ey_[i];
  }
  const Eigen::Vector3d c = LeastSquaresCircleFrom(x, y, c0_);
  double mn = HUGE_VAL, mx = -HUGE_VAL;
  for (Eigen::Index k = 0; k < n; ++k) {
    const double dx = x[k] - c[0], dy = y[k] - c[1];
    const double e = std::sqrt(dx * dx + dy * dy) - c[2];
    if (!out.empty()) out[static_cast<std::size_t>(k)] = e;
    mn = std::min(mn, e);
    mx = std::max(mx, e);
  }
  return {c, mn, mx, true};
}

}  // namespace km::geometry
