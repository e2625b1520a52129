#include "analysis/geometry/min_zone_circle.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/LU>

#include "analysis/core/errors.h"

namespace km::geometry {

namespace {

struct LinearisedZone {
  Eigen::Vector2d delta = Eigen::Vector2d::Zero();
  double width = 0.0;
  int iterations = 0;
  std::array<int, 4> basis{};  // the optimal basis (a warm start for the next linearisation)
};

// One linearisation about a centre c0: offsets d_i = |p_i − c0| − a common offset and unit vectors
// u_i, by coordinate so that they are computed a packet at a time.
struct Linearisation {
  Eigen::ArrayXd d, ux, uy;
  int Size() const { return static_cast<int>(d.size()); }
  double T(int i, const Eigen::Vector4d& x) const { return d[i] - x[0] * ux[i] - x[1] * uy[i]; }
  // Dual column j (p_j for j < n, q_{j−n} otherwise) and its cost.
  Eigen::Vector4d Column(int j) const {
    const int n = Size();
    if (j < n) return {ux[j], uy[j], 1.0, 0.0};
    return {-ux[j - n], -uy[j - n], 0.0, -1.0};
  }
  double Cost(int j) const { return j < Size() ? d[j] : -d[j - Size()]; }
};

// Pricing: the column with the largest reduced cost above `best` that is not in the basis
// (Dantzig), or the eligible one of lowest point index (Bland, after degenerate stalls); −1
// when none. With t_i = d_i − δ·u_i the reduced costs are r(p_i) = t_i − h and r(q_i) = l − t_i,
// the larger of the two per point. Only the points listed in `set` are priced.
int Entering(const Linearisation& z, const Eigen::Vector4d& x, const std::array<int, 4>& basis,
             double best, bool bland, const std::vector<int>& set) {
  const int n = z.Size();
  int enter = -1;
  for (const int i : set) {
    if (bland && enter >= 0 && i > enter % n) continue;  // Bland: the lowest point index
    const double t = z.T(i, x);
    const double rp = t - x[2], rq = x[3] - t;
    const double r = rp >= rq ? rp : rq;
    if (!(r > best)) continue;
    const int j = rp >= rq ? i : n + i;
    if (std::find(basis.begin(), basis.end(), j) != basis.end()) continue;
    enter = j;
    if (!bland) best = r;
  }
  return enter;
}

// Partial pricing: the simplex prices a working set of points (64 spread over the list, then
// those that violated the zone); when none of them can enter, every point is priced in one pass
// and the most violating ones join the set. The optimum is certified by that full
// pass, so it is the LP's over all points. The set is kept from one linearisation to the next.
class WorkingSet {
 public:
  // `size` points spread evenly over the list.
  WorkingSet(int n, int size) : in_(static_cast<std::size_t>(n), 0) {
    const int stride = std::max(1, n / std::max(1, size));
    for (int i = 0; i < n; i += stride) Add(i);
  }
  void Add(int i) {
    if (in_[static_cast<std::size_t>(i)]) return;
    in_[static_cast<std::size_t>(i)] = 1;
    set_.push_back(i);
  }
  const std::vector<int>& Points() const { return set_; }
  // Adds the points outside the set that violate the zone of x by more than tol, the worst
  // first (at most 16); false when there are none.
  bool Grow(const Linearisation& z, const Eigen::Vector4d& x, double tol);

 private:
  std::vector<char> in_;
  std::vector<int> set_;
  std::vector<std::pair<double, int>> violating_;
  Eigen::ArrayXd r_;  // reduced costs of a full pricing pass
};

bool WorkingSet::Grow(const Linearisation& z, const Eigen::Vector4d& x, double tol) {
  // Reduced costs a packet at a time; the points of the set are all priced out already.
  const Eigen::ArrayXd t = z.d - x[0] * z.ux - x[1] * z.uy;
  r_ = (t - x[2]).max(x[3] - t);
  violating_.clear();
  for (int i = 0; i < z.Size(); ++i) {
    if (r_[i] > tol && !in_[static_cast<std::size_t>(i)]) violating_.emplace_back(r_[i], i);
  }
  if (violating_.empty()) return false;
  constexpr std::size_t kJoin = 16;
  const auto k = std::min(kJoin, violating_.size());
  std::partial_sort(violating_.begin(), violating_.begin() + static_cast<std::ptrdiff_t>(k),
                    violating_.end(), std::greater<>());
  for (std::size_t j = 0; j < k; ++j) Add(violating_[j].second);
  return true;
}

// Initial feasible basis: p_i = q_i = 1 for one point i (weights balance trivially), plus two
// zero-level columns p_j, p_k that make the basis non-singular (points ~120° apart).
std::array<int, 4> InitialBasis(const Linearisation& z) {
  const int n = z.Size();
  const int i0 = 0;
  int best_j = -1, best_k = -1;
  double best_det = 0.0;
  for (int step : {n / 3, n / 4, n / 5, n / 6, 1}) {
    for (int off = 0; off < 8 && best_det < 1e-3; ++off) {
      const int j = std::min(n - 1, step + off);
      const int k = std::min(n - 1, 2 * step + off);
      if (j == i0 || k == i0 || j == k) continue;
      Eigen::Matrix4d b;
      b << z.Column(i0), z.Column(n + i0), z.Column(j), z.Column(k);
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
  return {i0, n + i0, best_j, best_k};
}

// Ratio test: the basis row that leaves when column w enters (−1 when the dual is unbounded).
int Leaving(const Eigen::Vector4d& w, const Eigen::Vector4d& y, const std::array<int, 4>& basis,
            bool bland, double* ratio) {
  int leave = -1;
  *ratio = std::numeric_limits<double>::infinity();
  for (int r = 0; r < 4; ++r) {
    if (w[r] > 1e-12) {
      const double t = std::max(0.0, y[r]) / w[r];
      if (t < *ratio - 1e-15 ||
          (bland && std::abs(t - *ratio) <= 1e-15 && leave >= 0 && basis[r] < basis[leave])) {
        *ratio = t;
        leave = r;
      }
    }
  }
  return leave;
}

// Primal:  min h − l  s.t.  δ·u_i + h ≥ d_i,  −δ·u_i − l ≥ −d_i,  x = (δx, δy, h, l) free.
// Dual:    max Σ y_j b_j  s.t.  Σ y_j a_j = c = (0, 0, 1, −1),  y ≥ 0, with
//          a(p_i) = (u_x, u_y, 1, 0), b = d_i;   a(q_i) = (−u_x, −u_y, 0, −1), b = −d_i.
// Reduced cost of column j for the simplex multipliers x (x = B^{-T} b_B, the primal point):
//   r_j = b_j − a_j·x  (> 0: the primal constraint j is violated → column may enter).
LinearisedZone SolveLinearised(const Linearisation& z, WorkingSet& set,
                               const std::optional<std::array<int, 4>>& warm) {
  const Eigen::Vector4d c(0.0, 0.0, 1.0, -1.0);
  Eigen::Matrix4d bmat, binv;
  Eigen::Vector4d y;  // basic weights
  auto factor = [&](const std::array<int, 4>& b) {
    for (int r = 0; r < 4; ++r) bmat.col(r) = z.Column(b[static_cast<std::size_t>(r)]);
    binv = bmat.inverse();
    y = binv * c;
  };
  // The last linearisation's optimal basis, while it stays a feasible (non-negative) one.
  std::array<int, 4> basis{};
  if (warm) {
    basis = *warm;
    factor(basis);
  }
  if (!warm || !(std::abs(bmat.determinant()) > 1e-12) || !(y.minCoeff() >= 0.0)) {
    basis = InitialBasis(z);
    factor(basis);
  }
  for (const int j : basis) set.Add(j % z.Size());
  const double tol = 1e-12 * std::max(1.0, z.d.abs().maxCoeff());
  const int max_iter = 100000;
  int degenerate_run = 0;
  int it = 0;
  Eigen::Vector4d x = Eigen::Vector4d::Zero();
  for (; it < max_iter; ++it) {
    Eigen::Vector4d bb;
    for (int r = 0; r < 4; ++r) bb[r] = z.Cost(basis[static_cast<std::size_t>(r)]);
    x = binv.transpose() * bb;  // primal point (δx, δy, h, l)
    // Pricing: Dantzig (largest violation), Bland (lowest index) after degenerate stalls.
    const bool bland = degenerate_run > 50;
    int enter = Entering(z, x, basis, tol, bland, set.Points());
    if (enter < 0 && set.Grow(z, x, tol)) enter = Entering(z, x, basis, tol, bland, set.Points());
    if (enter < 0) break;  // optimal: no point violates the zone
    double ratio = 0.0;
    const int leave = Leaving(binv * z.Column(enter), y, basis, bland, &ratio);
    if (leave < 0) throw DidNotConverge("minimum zone: unbounded dual (degenerate points)");
    degenerate_run = ratio <= 1e-15 ? degenerate_run + 1 : 0;
    basis[static_cast<std::size_t>(leave)] = enter;
    factor(basis);
  }
  if (it >= max_iter) throw DidNotConverge("minimum zone: simplex did not terminate");
  LinearisedZone res;
  res.delta = x.head<2>();
  res.width = x[2] - x[3];
  res.iterations = it;
  res.basis = basis;
  return res;
}

// The points by coordinate.
struct Points {
  Eigen::ArrayXd x, y;
  explicit Points(const std::vector<Eigen::Vector2d>& p)
      : x(static_cast<Eigen::Index>(p.size())), y(static_cast<Eigen::Index>(p.size())) {
    for (std::size_t i = 0; i < p.size(); ++i) {
      x[static_cast<Eigen::Index>(i)] = p[i].x();
      y[static_cast<Eigen::Index>(i)] = p[i].y();
    }
  }
  // |p_i − c|, as (p_i − c).norm().
  Eigen::ArrayXd Distances(const Eigen::Vector2d& c) const {
    return ((x - c.x()).square() + (y - c.y()).square()).sqrt();
  }
};

// The linearisation about c0; throws when a point coincides with it.
Linearisation Linearise(const Points& p, const Eigen::Vector2d& c0, double* dmin) {
  Linearisation z{p.Distances(c0), p.x - c0.x(), p.y - c0.y()};
  if (!(z.d > 0.0).all()) throw InvalidInput("", 0, "points", "a point coincides with the centre");
  const Eigen::ArrayXd inv = z.d.inverse();
  z.ux *= inv;
  z.uy *= inv;
  *dmin = z.d.minCoeff();
  // Subtract a common offset so the LP works on small numbers (the width is unchanged).
  z.d -= 0.5 * (*dmin + z.d.maxCoeff());
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
  if (points.size() < 4)
    throw InvalidInput("", 0, "points", "minimum zone needs at least 4 points");
  MinZoneCircleResult res;
  const Points p(points);
  Eigen::Vector2d c0 = initial_centre;
  std::optional<WorkingSet> set;
  std::optional<std::array<int, 4>> basis;
  for (int pass = 0; pass < 3; ++pass) {
    double dmin = 0.0;
    const Linearisation z = Linearise(p, c0, &dmin);
    if (!set) set.emplace(z.Size(), 64);
    const LinearisedZone lz = SolveLinearised(z, *set, basis);
    basis = lz.basis;
    res.simplex_iterations += lz.iterations;
    const double step = lz.delta.norm();
    c0 += lz.delta;
    res.linearisation_bound = step * step / (2.0 * std::max(dmin - step, 1e-300));
    // Stop when the neglected second-order term is negligible against the zone width.
    if (res.linearisation_bound <= 1e-9 * std::max(lz.width, 1e-12 * dmin)) break;
  }
  res.centre = c0;
  const Eigen::ArrayXd r = p.Distances(c0);
  res.inner_radius = r.minCoeff();
  res.outer_radius = r.maxCoeff();
  res.width = res.outer_radius - res.inner_radius;
  return res;
}

}  // namespace km::geometry
