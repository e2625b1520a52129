// The spatial check of the self-calibration (a warning only): points whose volumetric error
// departs from their nearest neighbours' far beyond the map's local scatter.
#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/QR>

#include "analysis/tracker/tracker_selfcal_stages.h"

namespace km::tracker::selfcal_stages {
namespace {

// The K nearest points (commanded positions) of each point in `idx`, among `idx`: the points
// are binned in cubic cells of about one point each, and rings of cells around a point's own
// cell are searched until no farther cell can hold a nearer point.
std::vector<std::vector<std::size_t>> NearestNeighbours(const std::vector<Eigen::Vector3d>& c,
                                                        const std::vector<std::size_t>& idx,
                                                        std::size_t K) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t i : idx) {
    lo = lo.cwiseMin(c[i]);
    hi = hi.cwiseMax(c[i]);
  }
  const double extent = std::max((hi - lo).maxCoeff(), 1e-9);
  double cell = extent / std::max(1.0, std::ceil(std::cbrt(static_cast<double>(idx.size()))));
  Eigen::Vector3i dims;
  for (;;) {
    for (int a = 0; a < 3; ++a) dims(a) = static_cast<int>((hi(a) - lo(a)) / cell) + 1;
    if (static_cast<double>(dims.prod()) <= 8.0 * static_cast<double>(idx.size()) + 64) break;
    cell *= 1.5;  // a few far-off points: fewer, larger cells
  }
  auto cell_of = [&](const Eigen::Vector3d& p) {
    Eigen::Vector3i q;
    for (int a = 0; a < 3; ++a) {
      q(a) = std::clamp(static_cast<int>((p(a) - lo(a)) / cell), 0, dims(a) - 1);
    }
    return q;
  };
  auto flat = [&](const Eigen::Vector3i& q) {
    return (static_cast<std::size_t>(q.z()) * static_cast<std::size_t>(dims.y()) +
            static_cast<std::size_t>(q.y())) *
               static_cast<std::size_t>(dims.x()) +
           static_cast<std::size_t>(q.x());
  };
  std::vector<std::vector<std::size_t>> bins(static_cast<std::size_t>(dims.prod()));
  for (std::size_t q = 0; q < idx.size(); ++q) bins[flat(cell_of(c[idx[q]]))].push_back(q);
  std::vector<std::vector<std::size_t>> out(idx.size());
  std::vector<std::pair<double, std::size_t>> best;  // max-heap of (squared distance, position)
  const int max_ring = dims.maxCoeff();
  for (std::size_t q = 0; q < idx.size(); ++q) {
    const Eigen::Vector3d& p = c[idx[q]];
    const Eigen::Vector3i home = cell_of(p);
    best.clear();
    for (int ring = 0; ring <= max_ring; ++ring) {
      for (int dz = -ring; dz <= ring; ++dz) {
        for (int dy = -ring; dy <= ring; ++dy) {
          // The cells of the ring's shell only: inside it, the two faces of dx = ±ring.
          const bool face = std::abs(dz) == ring || std::abs(dy) == ring;
          const int step = face || ring == 0 ? 1 : 2 * ring;
          for (int dx = -ring; dx <= ring; dx += step) {
            const Eigen::Vector3i nb = home + Eigen::Vector3i(dx, dy, dz);
            if ((nb.array() < 0).any() || (nb.array() >= dims.array()).any()) continue;
            for (std::size_t other : bins[flat(nb)]) {
              if (other == q) continue;
              const double d2 = (c[idx[other]] - p).squaredNorm();
              if (best.size() < K) {
                best.emplace_back(d2, other);
                std::push_heap(best.begin(), best.end());
              } else if (d2 < best.front().first) {
                std::pop_heap(best.begin(), best.end());
                best.back() = {d2, other};
                std::push_heap(best.begin(), best.end());
              }
            }
          }
        }
      }
      // Cells of the next ring are at least ring·cell away.
      const double reach = ring * cell;
      if (best.size() == K && best.front().first <= reach * reach) break;
    }
    for (const auto& [d2, other] : best) out[q].push_back(other);
  }
  return out;
}

// x^k for the small powers of the trend (as std::pow gives them: x·x is exactly rounded).
double Power(double x, int k) {
  double y = 1.0;
  for (int q = 0; q < k; ++q) y *= x;
  return y;
}

}  // namespace

std::vector<SpatialDeparture> SpatialDepartures(const std::vector<Eigen::Vector3d>& commanded,
                                                const std::vector<Eigen::Vector3d>& error_um,
                                                const std::vector<Eigen::Vector3d>& sigma_um,
                                                const std::vector<char>& use, double k) {
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (use[i] && error_um[i].allFinite()) idx.push_back(i);
  }
  const long np = static_cast<long>(idx.size());
  if (np < 20) return {};
  // Quadratic trend (linear below 40 points) in normalised coordinates, per component.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t i : idx) {
    lo = lo.cwiseMin(commanded[i]);
    hi = hi.cwiseMax(commanded[i]);
  }
  const Eigen::Vector3d mid = 0.5 * (lo + hi);
  const Eigen::Vector3d half = (0.5 * (hi - lo)).cwiseMax(1e-9);
  const int degree = np >= 40 ? 2 : 1;
  std::vector<std::array<int, 3>> powers;
  for (int a = 0; a <= degree; ++a) {
    for (int b = 0; a + b <= degree; ++b) {
      for (int c = 0; a + b + c <= degree; ++c) powers.push_back({a, b, c});
    }
  }
  Eigen::MatrixXd X(np, static_cast<long>(powers.size()));
  Eigen::MatrixXd E(np, 3);
  for (long r = 0; r < np; ++r) {
    const std::size_t i = idx[static_cast<std::size_t>(r)];
    const Eigen::Vector3d t = (commanded[i] - mid).cwiseQuotient(half);
    for (std::size_t q = 0; q < powers.size(); ++q) {
      const auto& p = powers[q];
      X(r, static_cast<long>(q)) = Power(t.x(), p[0]) * Power(t.y(), p[1]) * Power(t.z(), p[2]);
    }
    E.row(r) = error_um[i].transpose();
  }
  const Eigen::MatrixXd F = E - X * X.colPivHouseholderQr().solve(E);
  // Departure from the median of the nearest neighbours.
  const std::size_t K = 6;
  const auto nb = NearestNeighbours(commanded, idx, K);
  Eigen::MatrixXd D(np, 3);
  std::vector<double> v;
  for (long r = 0; r < np; ++r) {
    for (int comp = 0; comp < 3; ++comp) {
      v.clear();
      for (std::size_t q : nb[static_cast<std::size_t>(r)])
        v.push_back(F(static_cast<long>(q), comp));
      std::sort(v.begin(), v.end());
      const double med =
          v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
      D(r, comp) = F(r, comp) - med;
    }
  }
  // The map's local scatter: 90th percentile of the differences between neighbouring points
  // (an upper quantile, as a wavy field along one axis leaves most neighbours equal).
  Eigen::Vector3d scale;
  for (int comp = 0; comp < 3; ++comp) {
    std::vector<double> diff;
    for (long r = 0; r < np; ++r) {
      for (std::size_t q : nb[static_cast<std::size_t>(r)]) {
        diff.push_back(std::abs(F(r, comp) - F(static_cast<long>(q), comp)));
      }
    }
    const auto at = diff.begin() + static_cast<long>(0.9 * static_cast<double>(diff.size() - 1));
    std::nth_element(diff.begin(), at, diff.end());
    scale(comp) = *at;
  }
  std::vector<SpatialDeparture> out;
  for (long r = 0; r < np; ++r) {
    const std::size_t i = idx[static_cast<std::size_t>(r)];
    double z = 0;
    for (int comp = 0; comp < 3; ++comp) {
      const double s = sigma_um[i].allFinite() ? sigma_um[i](comp) : 0.0;
      const double denom = std::sqrt(scale(comp) * scale(comp) + s * s);
      z = std::max(z, std::abs(D(r, comp)) / std::max(denom, 1e-3));  // nm: not worth a word
    }
    if (z > k) {
      out.push_back(
          {i, D.row(r).transpose(), z, static_cast<int>(nb[static_cast<std::size_t>(r)].size())});
    }
  }
  return out;
}

}  // namespace km::tracker::selfcal_stages
