#include "analysis/geometry/min_zone_circle.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/LU>

#include "analysis/core/errors.h"

namespace km::geometry {

namespace {

struct LinearisedZone {
  Eigen::Vector2d delta = Eigen::Vector2d::Zero();
  double width = 0.0;
  int iterations = 0;
};

// Pricing: the column with the largest reduced cost above `best` that is not in the basis
// (Dantzig), or the first such column (Bland, after degenerate stalls); −1 when none. With
// t_i = d_i − δ·u_i the reduced costs are r(p_i) = t_i − h and r(q_i) = l − t_i; the larger of
// the two is computed for all points in one pass (`r`), then scanned.
int Entering(const std::vector<double>& d, const Eigen::ArrayXd& ux, const Eigen::ArrayXd& uy,
             const Eigen::Vector4d& x, const std::array<int, 4>& basis, double best, bool bland,
             Eigen::ArrayXd& r) {
  const int n = static_cast<int>(d.size());
  const double x0 = x[0], x1 = x[1], x2 = x[2], x3 = x[3];
  for (int i = 0; i < n; ++i) {
    const double t = d[i] - x0 * ux[i] - x1 * uy[i];
    const double rp = t - x2;
    const double rq = x3 - t;
    r[i] = rp >= rq ? rp : rq;
  }
  int enter = -1;
  for (int i = 0; i < n; ++i) {
    if (!(r[i] > best)) continue;
    const double t = d[i] - x0 * ux[i] - x1 * uy[i];
    const int j = t - x2 >= x3 - t ? i : n + i;
    if (std::find(basis.begin(), basis.end(), j) != basis.end()) continue;
    enter = j;
    best = r[i];
    if (bland) break;
  }
  return enter;
}

// Primal:  min h − l  s.t.  δ·u_i + h ≥ d_i,  −δ·u_i − l ≥ −d_i,  x = (δx, δy, h, l) free.
// Dual:    max Σ y_j b_j  s.t.  Σ y_j a_j = c = (0, 0, 1, −1),  y ≥ 0, with
//          a(p_i) = (u_x, u_y, 1, 0), b = d_i;   a(q_i) = (−u_x, −u_y, 0, −1), b = −d_i.
// Reduced cost of column j for the simplex multipliers x (x = B^{-T} b_B, the primal point):
//   r_j = b_j − a_j·x  (> 0: the primal constraint j is violated → column may enter).
LinearisedZone SolveLinearised(const std::vector<double>& d,
                               const std::vector<Eigen::Vector2d>& u) {
  const int n = static_cast<int>(d.size());
  auto column = [&](int j) {
    Eigen::Vector4d a;
    if (j < n) {
      a << u[j].x(), u[j].y(), 1.0, 0.0;
    } else {
      const auto& v = u[j - n];
      a << -v.x(), -v.y(), 0.0, -1.0;
    }
    return a;
  };
  auto cost = [&](int j) { return j < n ? d[j] : -d[j - n]; };
  Eigen::ArrayXd ux(n), uy(n), pricing(n);  // the unit vectors by coordinate; reduced costs
  for (int i = 0; i < n; ++i) {
    ux[i] = u[static_cast<std::size_t>(i)].x();
    uy[i] = u[static_cast<std::size_t>(i)].y();
  }

  // Initial feasible basis: p_i = q_i = 1 for one point i (weights balance trivially), plus two
  // zero-level columns p_j, p_k that make the basis non-singular (points ~120° apart).
  const int i0 = 0;
  int best_j = -1, best_k = -1;
  double best_det = 0.0;
  for (int step : {n / 3, n / 4, n / 5, n / 6, 1}) {
    for (int off = 0; off < 8 && best_det < 1e-3; ++off) {
      const int j = std::min(n - 1, step + off);
      const int k = std::min(n - 1, 2 * step + off);
      if (j == i0 || k == i0 || j == k) continue;
      Eigen::Matrix4d b;
      b.col(0) = column(i0);
      b.col(1) = column(n + i0);
      b.col(2) = column(j);
      b.col(3) = column(k);
      const double det = std::abs(b.determinant());
      if (det > best_det) {
        best_det = det;
        best_j = j;
        best_k = k;
      }
    }
    if (best_det >= 1e-3) break;
  }
  if (best_det < 1e-12) {
    throw InvalidInput("", 0, "points", "minimum zone: points are not spread around the centre");
  }
  std::array<int, 4> basis = {i0, n + i0, best_j, best_k};
  Eigen::Matrix4d bmat;
  for (int r = 0; r < 4; ++r) bmat.col(r) = column(basis[r]);
  Eigen::Matrix4d binv = bmat.inverse();
  const Eigen::Vector4d c(0.0, 0.0, 1.0, -1.0);
  Eigen::Vector4d y = binv * c;  // basic weights

  double scale = 0.0;
  for (double v : d) scale = std::max(scale, std::abs(v));
  const double tol = 1e-12 * std::max(1.0, scale);
  const int max_iter = 100000;
  int degenerate_run = 0;
  int it = 0;
  Eigen::Vector4d x = Eigen::Vector4d::Zero();
  for (; it < max_iter; ++it) {
    Eigen::Vector4d bb;
    for (int r = 0; r < 4; ++r) bb[r] = cost(basis[r]);
    x = binv.transpose() * bb;  // primal point (δx, δy, h, l)
    // Pricing: Dantzig (largest violation), Bland (lowest index) after degenerate stalls.
    const bool bland = degenerate_run > 50;
    const int enter = Entering(d, ux, uy, x, basis, tol, bland, pricing);
    if (enter < 0) break;  // optimal
    const Eigen::Vector4d w = binv * column(enter);
    int leave = -1;
    double ratio = std::numeric_limits<double>::infinity();
    for (int r = 0; r < 4; ++r) {
      if (w[r] > 1e-12) {
        const double t = std::max(0.0, y[r]) / w[r];
        if (t < ratio - 1e-15 ||
            (bland && std::abs(t - ratio) <= 1e-15 && leave >= 0 && basis[r] < basis[leave])) {
          ratio = t;
          leave = r;
        }
      }
    }
    if (leave < 0) throw DidNotConverge("minimum zone: unbounded dual (degenerate points)");
    degenerate_run = ratio <= 1e-15 ? degenerate_run + 1 : 0;
    basis[leave] = enter;
    for (int r = 0; r < 4; ++r) bmat.col(r) = column(basis[r]);
    binv = bmat.inverse();
    y = binv * c;
  }
  if (it >= max_iter) throw DidNotConverge("minimum zone: simplex did not terminate");
  LinearisedZone z;
  z.delta = x.head<2>();
  z.width = x[2] - x[3];
  z.iterations = it;
  return z;
}

}  // namespace

double ZoneWidthAbout(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& centre) {
  double mn = std::numeric_limits<double>::infinity();
  double mx = -mn;
  for (const auto& p : points) {
    const double r = (p - centre).norm();
    mn = std::min(mn, r);
    mx = std::max(mx, r);
  }
  return mx - mn;
}

MinZoneCircleResult FitMinZoneCircle(const std::vector<Eigen::Vector2d>& points,
                                     const Eigen::Vector2d& initial_centre) {
  const std::size_t n = points.size();
  if (n < 4) throw InvalidInput("", 0, "points", "minimum zone needs at least 4 points");
  MinZoneCircleResult res;
  Eigen::Vector2d c0 = initial_centre;
  std::vector<double> d(n);
  std::vector<Eigen::Vector2d> u(n);
  double dmin = std::numeric_limits<double>::infinity();
  for (int pass = 0; pass < 3; ++pass) {
    dmin = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d v = points[i] - c0;
      d[i] = v.norm();
      if (!(d[i] > 0.0)) throw InvalidInput("", 0, "points", "a point coincides with the centre");
      u[i] = v / d[i];
      dmin = std::min(dmin, d[i]);
    }
    // Subtract a common offset so the LP works on small numbers (the width is unchanged).
    double mean = 0.0;
    for (double v : d) mean += v;
    mean /= static_cast<double>(n);
    std::vector<double> dd(n);
    for (std::size_t i = 0; i < n; ++i) dd[i] = d[i] - mean;
    const LinearisedZone z = SolveLinearised(dd, u);
    res.simplex_iterations += z.iterations;
    const double step = z.delta.norm();
    c0 += z.delta;
    res.linearisation_bound = step * step / (2.0 * std::max(dmin - step, 1e-300));
    // Stop when the neglected second-order term is negligible against the zone width.
    if (res.linearisation_bound <= 1e-9 * std::max(z.width, 1e-12 * dmin)) break;
  }
  res.centre = c0;
  double mn = std::numeric_limits<double>::infinity(), mx = -mn;
  for (const auto& p : points) {
    const double r = (p - c0).norm();
    mn = std::min(mn, r);
    mx = std::max(mx, r);
  }
  res.inner_radius = mn;
  res.outer_radius = mx;
  res.width = mx - mn;
  return res;
}

}  // namespace km::geometry
