// Minimum-zone circle: exact LP solution vs an independent brute-force search over centres.
#include "analysis/geometry/min_zone_circle.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "analysis/core/errors.h"
#include "analysis/geometry/circle_fit.h"

namespace km::geometry {
namespace {

// Planar DBB-like trace: radius 150 mm in µm, form error of a few µm (harmonics + noise).
std::vector<Eigen::Vector2d> Trace(unsigned seed, std::size_t n, Eigen::Vector2d centre) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, 0.3);
  double a[6], ph[6];
  for (int k = 0; k < 6; ++k) {
    a[k] = 2.0 * std::abs(u(rng)) / (1 + k);
    ph[k] = 3.0 * u(rng);
  }
  std::vector<Eigen::Vector2d> pts;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = 2.0 * std::numbers::pi * (static_cast<double>(i) + 0.3 * u(rng)) / n;
    double r = 150000.0 + g(rng);
    for (int k = 0; k < 6; ++k) r += a[k] * std::cos((k + 2) * t - ph[k]);
    pts.push_back(centre + r * Eigen::Vector2d(std::cos(t), std::sin(t)));
  }
  return pts;
}

// Brute force: zone width on a grid of centres, zoomed three times around the best grid point.
double BruteForce(const std::vector<Eigen::Vector2d>& pts, Eigen::Vector2d c, double half,
                  double* resolution) {
  const int m = 40;
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector2d bc = c;
  for (int level = 0; level < 4; ++level) {
    const double h = 2.0 * half / m;
    Eigen::Vector2d centre = bc;
    for (int i = 0; i <= m; ++i) {
      for (int j = 0; j <= m; ++j) {
        const Eigen::Vector2d q = centre + Eigen::Vector2d(-half + i * h, -half + j * h);
        const double w = ZoneWidthAbout(pts, q);
        if (w < best) {
          best = w;
          bc = q;
        }
      }
    }
    *resolution = h;
    half = 2.0 * h;
  }
  return best;
}

TEST(MinZoneCircle, MatchesBruteForceAndBeatsLeastSquares) {
  for (unsigned seed : {1u, 2u, 3u, 4u, 5u}) {
    const Eigen::Vector2d c0(12.0 * seed, -7.0);
    const auto pts = Trace(seed, 720, c0);
    const auto ls = FitCircleLeastSquares(pts);
    const auto mz = FitMinZoneCircle(pts, ls.circle.centre);
    double res = 0.0;
    const double bf = BruteForce(pts, ls.circle.centre, 4.0, &res);
    // The brute force samples centres; the exact optimum can only be lower, and within the
    // Lipschitz bound 2·|Δc| ≤ √2·h of the best grid point.
    EXPECT_LE(mz.width, bf + 1e-9) << "seed " << seed;
    EXPECT_GE(mz.width, bf - std::sqrt(2.0) * res - 1e-9) << "seed " << seed;
    EXPECT_LE(mz.width, ZoneWidthAbout(pts, ls.circle.centre) + 1e-12);
    EXPECT_NEAR(mz.outer_radius - mz.inner_radius, mz.width, 1e-9);
    EXPECT_LT(mz.linearisation_bound, 1e-6);
  }
}

TEST(MinZoneCircle, ExactForAnIdealZone) {
  // Points alternately on two concentric circles (4 extremes at 90° alternating) → width 2 µm.
  std::vector<Eigen::Vector2d> pts;
  const Eigen::Vector2d c(3.0, 4.0);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.9, 0.9);
  for (int i = 0; i < 400; ++i) {
    const double t = 2.0 * std::numbers::pi * i / 400.0;
    double d = u(rng);
    if (i % 100 == 0) d = (i / 100) % 2 == 0 ? 1.0 : -1.0;
    pts.push_back(c + (100000.0 + d) * Eigen::Vector2d(std::cos(t), std::sin(t)));
  }
  const auto mz = FitMinZoneCircle(pts, c + Eigen::Vector2d(1.5, -2.0));
  EXPECT_NEAR(mz.width, 2.0, 1e-6);
  EXPECT_NEAR(mz.centre.x(), c.x(), 1e-4);
  EXPECT_NEAR(mz.centre.y(), c.y(), 1e-4);
}

// A dense trace whose zone is set by a few isolated points (a short bump out and a dip in,
// between the points the search starts from): the zone found must hold every point and match
// the brute force.
TEST(MinZoneCircle, IsolatedExtremesAmongManyPointsSetTheZone) {
  for (unsigned seed : {21u, 22u}) {
    auto pts = Trace(seed, 7200, Eigen::Vector2d(-5.0, 9.0));
    for (std::size_t i : {std::size_t{1237}, std::size_t{1238}, std::size_t{5001}}) {
      const Eigen::Vector2d v = pts[i] - Eigen::Vector2d(-5.0, 9.0);
      pts[i] += (i == 5001 ? -9.0 : 7.5) * v.normalized();
    }
    const auto ls = FitCircleLeastSquares(pts);
    const auto mz = FitMinZoneCircle(pts, ls.circle.centre);
    for (const auto& p : pts) {
      const double r = (p - mz.centre).norm();
      EXPECT_GE(r, mz.inner_radius - 1e-9);
      EXPECT_LE(r, mz.outer_radius + 1e-9);
    }
    double res = 0.0;
    const double bf = BruteForce(pts, ls.circle.centre, 6.0, &res);
    EXPECT_LE(mz.width, bf + 1e-9) << "seed " << seed;
    EXPECT_GE(mz.width, bf - std::sqrt(2.0) * res - 1e-9) << "seed " << seed;
  }
}

TEST(MinZoneCircle, RejectsTooFewPoints) {
  std::vector<Eigen::Vector2d> pts = {{1, 0}, {0, 1}, {-1, 0}};
  EXPECT_THROW(FitMinZoneCircle(pts, Eigen::Vector2d::Zero()), km::InvalidInput);
}

}  // namespace
}  // namespace km::geometry
