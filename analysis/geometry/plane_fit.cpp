#include "analysis/geometry/plane_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "analysis/core/errors.h"

namespace km::geometry {
namespace {

void CheckSizes(std::span<const double> x, std::span<const double> y, std::span<const double> z) {
  if (x.size() != y.size() || x.size() != z.size()) {
    throw InvalidInput("plane fit: x, y and z differ in size");
  }
  if (x.size() < 3) throw NotObservable("plane fit: at least three points are needed");
}

// Centring and scaling so that the simplex tolerances are relative.
struct Normalised {
  double mx = 0, my = 0, mz = 0, sx = 1, sy = 1, sz = 1;
  std::vector<double> x, y, z;
};

Normalised Normalise(std::span<const double> x, std::span<const double> y,
                     std::span<const double> z) {
  Normalised n;
  const double count = static_cast<double>(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    n.mx += x[i];
    n.my += y[i];
    n.mz += z[i];
  }
  n.mx /= count;
  n.my /= count;
  n.mz /= count;
  double ax = 0, ay = 0, az = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    ax = std::max(ax, std::abs(x[i] - n.mx));
    ay = std::max(ay, std::abs(y[i] - n.my));
    az = std::max(az, std::abs(z[i] - n.mz));
  }
  if (!(ax > 0.0) || !(ay > 0.0)) {
    throw NotObservable("plane fit: the (x, y) positions are collinear");
  }
  n.sx = ax;
  n.sy = ay;
  n.sz = az > 0.0 ? az : 1.0;
  n.x.resize(x.size());
  n.y.resize(x.size());
  n.z.resize(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    n.x[i] = (x[i] - n.mx) / n.sx;
    n.y[i] = (y[i] - n.my) / n.sy;
    n.z[i] = (z[i] - n.mz) / n.sz;
  }
  return n;
}

// Plane in normalised coordinates -> plane in the caller's coordinates.
Plane3 Denormalise(const Normalised& n, double a, double b, double c) {
  Plane3 p;
  p.slope_x = a * n.sz / n.sx;
  p.slope_y = b * n.sz / n.sy;
  p.offset = n.mz + c * n.sz - p.slope_x * n.mx - p.slope_y * n.my;
  return p;
}

// Three points k, p, q spanning a large triangle in (x, y): k the lowest-left, p the farthest
// from it, q the farthest from the line k–p (NotObservable when the points are collinear).
std::array<std::size_t, 3> StartingTriangle(const Normalised& n) {
  const std::size_t count = n.x.size();
  std::size_t k = 0;
  for (std::size_t i = 1; i < count; ++i) {
    if (n.x[i] < n.x[k] || (n.x[i] == n.x[k] && n.y[i] < n.y[k])) k = i;
  }
  std::size_t p = k;
  double best = -1.0;
  for (std::size_t i = 0; i < count; ++i) {
    const double d = std::hypot(n.x[i] - n.x[k], n.y[i] - n.y[k]);
    if (d > best) {
      best = d;
      p = i;
    }
  }
  std::size_t q = k;
  best = -1.0;
  const double ux = n.x[p] - n.x[k], uy = n.y[p] - n.y[k];
  for (std::size_t i = 0; i < count; ++i) {
    const double area = std::abs(ux * (n.y[i] - n.y[k]) - uy * (n.x[i] - n.x[k]));
    if (area > best) {
      best = area;
      q = i;
    }
  }
  // Area relative to the (normalised, O(1)) extent of the points.
  if (!(best > 1e-9)) throw NotObservable("plane fit: the (x, y) positions are collinear");
  return {k, p, q};
}

}  // namespace

Plane3 FitPlaneLeastSquares(std::span<const double> x, std::span<const double> y,
                            std::span<const double> z) {
  CheckSizes(x, y, z);
  const Normalised n = Normalise(x, y, z);
  Eigen::Matrix2d m = Eigen::Matrix2d::Zero();
  Eigen::Vector2d r = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < n.x.size(); ++i) {
    const Eigen::Vector2d v(n.x[i], n.y[i]);
    m += v * v.transpose();
    r += v * n.z[i];
  }
  // Normalised coordinates: a well-posed fit has det of order count^2.
  const double count = static_cast<double>(n.x.size());
  if (!(m.determinant() > 1e-12 * count * count)) {
    throw NotObservable("plane fit: the (x, y) positions are collinear");
  }
  const Eigen::Vector2d ab = m.ldlt().solve(r);
  // Centred data: the least-squares offset at the centroid is the mean, i.e. 0.
  return Denormalise(n, ab(0), ab(1), 0.0);
}

MinimumZonePlane FitPlaneMinimumZone(std::span<const double> x, std::span<const double> y,
                                     std::span<const double> z) {
  CheckSizes(x, y, z);
  const Normalised n = Normalise(x, y, z);
  const std::size_t count = n.x.size();
  const auto column = [&](std::size_t j) {
    if (j < count) return Eigen::Vector4d(1.0, 0.0, n.x[j], n.y[j]);  // lambda_j
    const std::size_t i = j - count;
    return Eigen::Vector4d(0.0, 1.0, -n.x[i], -n.y[i]);  // mu_i
  };
  const auto cost = [&](std::size_t j) { return j < count ? n.z[j] : -n.z[j - count]; };

  // Starting basis {lambda_k, mu_k, lambda_p, lambda_q} with k, p, q spanning a large
  // triangle: lambda_k = mu_k = 1 is feasible, the other two are at zero (degenerate).
  const auto [k, p, q] = StartingTriangle(n);
  std::array<std::size_t, 4> basis{k, count + k, p, q};
  const Eigen::Vector4d rhs(1.0, 1.0, 0.0, 0.0);
  Eigen::Matrix4d binv;
  Eigen::Vector4d xb;
  const auto refactor = [&]() {
    Eigen::Matrix4d bm;
    for (int r = 0; r < 4; ++r) bm.col(r) = column(basis[static_cast<std::size_t>(r)]);
    Eigen::FullPivLU<Eigen::Matrix4d> lu(bm);
    if (!lu.isInvertible()) throw DidNotConverge("minimum-zone plane: singular simplex basis");
    binv = lu.inverse();
    xb = binv * rhs;
    for (int r = 0; r < 4; ++r) xb(r) = std::max(xb(r), 0.0);
  };
  refactor();

  constexpr double kCostTol = 1e-12;
  constexpr double kPivotTol = 1e-11;
  const int max_iterations = static_cast<int>(std::min<std::size_t>(20 * count + 1000, 2000000));
  int degenerate_run = 0;
  MinimumZonePlane out;
  Eigen::Vector4d pi;
  for (int it = 0;; ++it) {
    if (it >= max_iterations) {
      throw DidNotConverge("minimum-zone plane: simplex pivot limit reached");
    }
    Eigen::Vector4d cb;
    for (int r = 0; r < 4; ++r) cb(r) = cost(basis[static_cast<std::size_t>(r)]);
    pi = binv.transpose() * cb;
    // Reduced costs: lambda_j -> r_j - pi0, mu_j -> -r_j - pi1 with r_j = z_j - pi2 x_j - pi3 y_j.
    const bool bland = degenerate_run > 50;
    std::size_t enter = 2 * count;
    double enter_d = kCostTol;
    std::size_t first_mu = 2 * count;
    for (std::size_t j = 0; j < count; ++j) {
      const double r = n.z[j] - pi(2) * n.x[j] - pi(3) * n.y[j];
      const double dl = r - pi(0);
      const double dm = -r - pi(1);
      if (bland) {
        // Smallest index first: every lambda_j comes before every mu_j.
        if (dl > kCostTol) {
          enter = j;
          break;
        }
        if (dm > kCostTol && first_mu == 2 * count) first_mu = j + count;
        continue;
      }
      if (dl > enter_d) {
        enter_d = dl;
        enter = j;
      }
      if (dm > enter_d) {
        enter_d = dm;
        enter = j + count;
      }
    }
    if (bland && enter == 2 * count) enter = first_mu;
    if (enter == 2 * count) {
      out.iterations = it;
      break;
    }
    const Eigen::Vector4d w = binv * column(enter);
    int leave = -1;
    double theta = std::numeric_limits<double>::infinity();
    for (int r = 0; r < 4; ++r) {
      if (w(r) <= kPivotTol) continue;
      const double t = xb(r) / w(r);
      const bool better =
          t < theta - 1e-15 ||
          (t <= theta + 1e-15 && leave >= 0 &&
           (bland ? basis[static_cast<std::size_t>(r)] < basis[static_cast<std::size_t>(leave)]
                  : w(r) > w(leave)));
      if (leave < 0 || better) {
        theta = t;
        leave = r;
      }
    }
    if (leave < 0) throw DidNotConverge("minimum-zone plane: unbounded simplex step");
    degenerate_run = theta <= 1e-14 ? degenerate_run + 1 : 0;
    basis[static_cast<std::size_t>(leave)] = enter;
    refactor();
  }
  // Enclosing planes from the optimal multipliers; the zone is re-measured on all points.
  double hi = -std::numeric_limits<double>::infinity();
  double lo = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < count; ++i) {
    const double r = n.z[i] - pi(2) * n.x[i] - pi(3) * n.y[i];
    hi = std::max(hi, r);
    lo = std::min(lo, r);
  }
  out.centre = Denormalise(n, pi(2), pi(3), 0.5 * (hi + lo));
  out.width = PeakToValley(x, y, z, out.centre);
  return out;
}

double PeakToValley(std::span<const double> x, std::span<const double> y, std::span<const double> z,
                    const Plane3& plane) {
  if (x.size() != y.size() || x.size() != z.size()) {
    throw InvalidInput("peak to valley: x, y and z differ in size");
  }
  if (x.empty()) return 0.0;
  double hi = -std::numeric_limits<double>::infinity();
  double lo = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = z[i] - plane(x[i], y[i]);
    hi = std::max(hi, r);
    lo = std::min(lo, r);
  }
  return hi - lo;
}

}  // namespace km::geometry
