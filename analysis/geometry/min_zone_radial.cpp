#include "analysis/geometry/min_zone_radial.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "analysis/geometry/min_zone_circle.h"

namespace km::geometry {

void RadialMinZone::Init(std::span<const double> x, std::span<const double> y,
                         std::span<const double> ex, std::span<const double> ey,
                         const Eigen::Vector2d& centre, double band) {
  const std::size_t n = x.size();
  centre_ = centre;
  band_ = band;
  x0_.assign(x.begin(), x.end());
  y0_.assign(y.begin(), y.end());
  ex_.assign(ex.begin(), ex.end());
  ey_.assign(ey.begin(), ey.end());
  d0_.resize(n);
  a_.resize(n);
  v_.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double vx = x[k] - centre.x(), vy = y[k] - centre.y();
    d0_[k] = std::sqrt(vx * vx + vy * vy);
    a_[k] = d0_[k] > 0.0 ? (ex[k] * vx + ey[k] * vy) / d0_[k] : 1.0;
  }
  in_.assign(n, 0);
  const std::size_t step = std::max<std::size_t>(1, n / 16);
  skeleton_.clear();
  for (std::size_t k = 0; k < n; k += step) skeleton_.push_back(k);
}

void RadialMinZone::Add(std::size_t k) {
  if (in_[k]) return;
  in_[k] = 1;
  cand_.push_back(k);
}

template <class Point>
double RadialMinZone::Solve(std::span<const double> v, Point&& point) {
  const std::size_t n = d0_.size();
  const Eigen::Map<const Eigen::ArrayXd> va(v.data(), static_cast<Eigen::Index>(n));
  const double hi = va.maxCoeff(), lo = va.minCoeff();
  cand_.clear();
  for (std::size_t k : skeleton_) Add(k);
  const double top = hi - band_, bottom = lo + band_;
  for (std::size_t k = 0; k < n; ++k) {
    if (v[k] >= top || v[k] <= bottom) [[unlikely]]
      Add(k);
  }
  double width = 0.0;
  for (int round = 0; round < 50; ++round) {
    sub_.resize(cand_.size());
    for (std::size_t j = 0; j < cand_.size(); ++j) sub_[j] = point(cand_[j]);
    const MinZoneCircleResult z = FitMinZoneCircle(sub_, centre_);
    width = z.width;
    // Outside the zone by more than 1e-7: compared on squared distances (no square roots).
    const double tol = 1e-7;
    const double out2 = (z.outer_radius + tol) * (z.outer_radius + tol);
    const double in2 = z.inner_radius > tol ? (z.inner_radius - tol) * (z.inner_radius - tol) : 0.0;
    const std::size_t before = cand_.size();
    for (std::size_t k = 0; k < n; ++k) {
      const Eigen::Vector2d p = point(k) - z.centre;
      const double d2 = p.squaredNorm();
      if ((d2 > out2 || d2 < in2) && !in_[k]) [[unlikely]]
        Add(k);
    }
    if (cand_.size() == before) break;
  }
  for (std::size_t k : cand_) in_[k] = 0;
  return width;
}

double RadialMinZone::Width(std::span<const double> s) {
  const auto n = static_cast<Eigen::Index>(d0_.size());
  Eigen::Map<Eigen::ArrayXd>(v_.data(), n) = Eigen::Map<const Eigen::ArrayXd>(d0_.data(), n) +
                                             Eigen::Map<const Eigen::ArrayXd>(a_.data(), n) *
                                                 Eigen::Map<const Eigen::ArrayXd>(s.data(), n);
  return Solve(v_, [&](std::size_t k) {
    return Eigen::Vector2d(x0_[k] + s[k] * ex_[k], y0_[k] + s[k] * ey_[k]);
  });
}

double RadialMinZone::Width(const std::vector<Eigen::Vector2d>& pts,
                            std::span<const double> shift) {
  const std::size_t n = d0_.size();
  for (std::size_t k = 0; k < n; ++k) v_[k] = d0_[k] + shift[k];
  return Solve(v_, [&](std::size_t k) { return pts[k]; });
}

}  // namespace km::geometry
