// Reference lines and planes: recover-the-truth for least squares, and the exact minimum-zone
// line / plane against independent computations (all-pairs slopes for the line, nested
// golden-section search for the plane, and the line algorithm for a plane whose form depends
// on x only).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/geometry/convex_hull.h"
#include "analysis/geometry/line_fit.h"
#include "analysis/geometry/plane_fit.h"

namespace km::geometry {
namespace {

double LineWidthAt(const std::vector<double>& x, const std::vector<double>& y, double m) {
  double hi = -std::numeric_limits<double>::infinity(), lo = -hi;
  for (std::size_t i = 0; i < x.size(); ++i) {
    hi = std::max(hi, y[i] - m * x[i]);
    lo = std::min(lo, y[i] - m * x[i]);
  }
  return hi - lo;
}

// Independent exact minimum zone: the optimal slope joins two of the points, so try them all.
double BruteForceLineZone(const std::vector<double>& x, const std::vector<double>& y) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < x.size(); ++i) {
    for (std::size_t j = i + 1; j < x.size(); ++j) {
      if (x[j] == x[i]) continue;
      best = std::min(best, LineWidthAt(x, y, (y[j] - y[i]) / (x[j] - x[i])));
    }
  }
  return best;
}

double PlaneWidthAt(const std::vector<double>& x, const std::vector<double>& y,
                    const std::vector<double>& z, double a, double b) {
  double hi = -std::numeric_limits<double>::infinity(), lo = -hi;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = z[i] - a * x[i] - b * y[i];
    hi = std::max(hi, r);
    lo = std::min(lo, r);
  }
  return hi - lo;
}

template <typename F>
double GoldenMin(F f, double lo, double hi, int iterations) {
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double c = hi - g * (hi - lo), d = lo + g * (hi - lo);
  double fc = f(c), fd = f(d);
  for (int i = 0; i < iterations; ++i) {
    if (fc < fd) {
      hi = d;
      d = c;
      fd = fc;
      c = hi - g * (hi - lo);
      fc = f(c);
    } else {
      lo = c;
      c = d;
      fc = fd;
      d = lo + g * (hi - lo);
      fd = f(d);
    }
  }
  return std::min(fc, fd);
}

// Independent minimum zone of a plane: W(a, b) is convex, so min_b W is convex in a; nested
// golden-section searches over a generous slope box around the least-squares slopes.
double NestedSearchPlaneZone(const std::vector<double>& x, const std::vector<double>& y,
                             const std::vector<double>& z) {
  const Plane3 ls = FitPlaneLeastSquares(x, y, z);
  const double pv = PeakToValley(x, y, z, ls);
  const auto [x0, x1] = std::minmax_element(x.begin(), x.end());
  const auto [y0, y1] = std::minmax_element(y.begin(), y.end());
  const double ra = 4.0 * pv / (*x1 - *x0) + 1e-9;
  const double rb = 4.0 * pv / (*y1 - *y0) + 1e-9;
  return GoldenMin(
      [&](double a) {
        return GoldenMin([&](double b) { return PlaneWidthAt(x, y, z, a, b); }, ls.slope_y - rb,
                         ls.slope_y + rb, 90);
      },
      ls.slope_x - ra, ls.slope_x + ra, 90);
}

TEST(ConvexHull, EveryPointInsideAndPolygonConvex) {
  for (unsigned seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> g(0.0, 1.0);
    std::vector<double> x(200), y(200);
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] = g(rng);
      y[i] = g(rng);
    }
    const auto hull = ConvexHull2D(x, y);
    ASSERT_GE(hull.size(), 3u);
    for (std::size_t k = 0; k < hull.size(); ++k) {
      const std::size_t a = hull[k], b = hull[(k + 1) % hull.size()];
      for (std::size_t i = 0; i < x.size(); ++i) {
        const double cross = (x[b] - x[a]) * (y[i] - y[a]) - (y[b] - y[a]) * (x[i] - x[a]);
        EXPECT_GE(cross, -1e-12) << "point " << i << " outside edge " << k;
      }
    }
  }
}

TEST(LineFit, LeastSquaresRecoversSlopeAndIntercept) {
  for (unsigned seed : {11u, 12u, 13u, 14u}) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> jitter(-0.3, 0.3);
    std::normal_distribution<double> noise(0.0, 0.05);
    const double slope = 0.042, intercept = -3.5;  // um/mm, um
    std::vector<double> x, y;
    for (int i = 0; i < 400; ++i) {
      x.push_back(100.0 + i + jitter(rng));
      y.push_back(intercept + slope * x.back() + noise(rng));
    }
    const Line2 l = FitLineLeastSquares(x, y);
    // sigma_slope = 0.05 / sqrt(sum (x - mean)^2) ~ 2.2e-5 um/mm; 5 sigma.
    EXPECT_NEAR(l.slope, slope, 1.1e-4);
    EXPECT_NEAR(l(300.0), intercept + slope * 300.0, 0.02);
  }
}

TEST(LineFit, MinimumZoneMatchesAllPairsBruteForce) {
  for (unsigned seed : {21u, 22u, 23u, 24u, 25u}) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> noise(0.0, 0.5);
    std::vector<double> x, y;
    double pos = 0.0;
    for (int i = 0; i < 60; ++i) {
      pos += 0.2 + 5.0 * u(rng);  // non-uniform spacing
      x.push_back(pos);
      y.push_back(0.01 * pos + 0.8 * std::sin(pos / 17.0) + noise(rng));
    }
    const MinimumZoneLine z = FitLineMinimumZone(x, y);
    const double brute = BruteForceLineZone(x, y);
    EXPECT_NEAR(z.width, brute, 1e-3) << "seed " << seed;
    EXPECT_NEAR(z.width, brute, 1e-9 * (1.0 + brute)) << "seed " << seed;
    // The zone encloses every point and is never wider than the other references.
    EXPECT_NEAR(PeakToValley(x, y, z.centre), z.width, 1e-12);
    EXPECT_LE(z.width, PeakToValley(x, y, FitLineLeastSquares(x, y)) + 1e-12);
    EXPECT_LE(z.width, PeakToValley(x, y, LineThroughEndPoints(x, y)) + 1e-12);
  }
}

TEST(LineFit, MinimumZoneOfAKnownShape) {
  // A symmetric V: y = |x| sampled at -10..10 has minimum zone 10 (horizontal lines 0 and 10),
  // while the end-point line is also horizontal.
  std::vector<double> x, y;
  for (int i = -10; i <= 10; ++i) {
    x.push_back(i);
    y.push_back(std::abs(i));
  }
  const MinimumZoneLine z = FitLineMinimumZone(x, y);
  EXPECT_NEAR(z.width, 10.0, 1e-12);
  EXPECT_NEAR(z.centre.slope, 0.0, 1e-12);
  // Collinear points: zero width, slope recovered.
  std::vector<double> yl;
  for (double xi : x) yl.push_back(2.0 - 0.5 * xi);
  const MinimumZoneLine zl = FitLineMinimumZone(x, yl);
  EXPECT_NEAR(zl.width, 0.0, 1e-12);
  EXPECT_NEAR(zl.centre.slope, -0.5, 1e-12);
  EXPECT_THROW(FitLineMinimumZone(std::vector<double>{1.0, 1.0}, std::vector<double>{0.0, 1.0}),
               NotObservable);
}

TEST(PlaneFit, LeastSquaresRecoversThePlane) {
  for (unsigned seed : {31u, 32u, 33u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.5);
    const double a = 0.12, b = -0.075, c = 14.0;  // um/mm, um/mm, um
    std::vector<double> x, y, z;
    for (int i = 0; i < 10; ++i) {
      for (int j = 0; j < 10; ++j) {
        x.push_back(-190.0 + 380.0 * i / 9.0);
        y.push_back(-190.0 + 380.0 * j / 9.0);
        z.push_back(c + a * x.back() + b * y.back() + noise(rng));
      }
    }
    const Plane3 p = FitPlaneLeastSquares(x, y, z);
    // sigma_slope = 0.5 / sqrt(100 * var(x)) ~ 4e-4 um/mm; 5 sigma.
    EXPECT_NEAR(p.slope_x, a, 2e-3);
    EXPECT_NEAR(p.slope_y, b, 2e-3);
    EXPECT_NEAR(p.offset, c, 0.25);
  }
}

TEST(PlaneFit, MinimumZoneMatchesNestedSearch) {
  for (unsigned seed : {41u, 42u, 43u, 44u, 45u, 46u}) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::normal_distribution<double> noise(0.0, 1.0);
    std::vector<double> x, y, z;
    const bool grid = seed % 2 == 0;  // regular grids are degenerate for the simplex
    for (int i = 0; i < 64; ++i) {
      const double xi = grid ? -260.0 + 520.0 * (i % 8) / 7.0 : 260.0 * u(rng);
      const double yi = grid ? -260.0 + 520.0 * (i / 8) / 7.0 : 260.0 * u(rng);
      x.push_back(xi);
      y.push_back(yi);
      z.push_back(0.3 * xi - 0.1 * yi + 2e-4 * xi * yi + 3.0 * std::cos(xi / 90.0) + noise(rng));
    }
    const MinimumZonePlane mz = FitPlaneMinimumZone(x, y, z);
    const double independent = NestedSearchPlaneZone(x, y, z);
    EXPECT_NEAR(mz.width, independent, 1e-3) << "seed " << seed;
    EXPECT_LE(mz.width, independent + 1e-9) << "seed " << seed;
    EXPECT_NEAR(PeakToValley(x, y, z, mz.centre), mz.width, 1e-9);
    EXPECT_LE(mz.width, PeakToValley(x, y, z, FitPlaneLeastSquares(x, y, z)) + 1e-9);
  }
}

TEST(PlaneFit, MinimumZoneMatchesNestedSearchOnLargeAndTiedInputs) {
  // 2500 scattered points, and a grid with integer readings (many ties: degenerate pivots).
  for (unsigned seed : {47u, 48u}) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::normal_distribution<double> noise(0.0, 2.0);
    std::vector<double> x, y, z;
    const bool ties = seed == 48u;
    const int n = ties ? 225 : 2500;
    for (int i = 0; i < n; ++i) {
      const double xi = ties ? 10.0 * (i % 15) : 190.0 * u(rng);
      const double yi = ties ? 10.0 * (i / 15) : 190.0 * u(rng);
      x.push_back(xi);
      y.push_back(yi);
      const double zi = 0.05 * xi + 0.02 * yi + noise(rng);
      z.push_back(ties ? std::round(zi) : zi);
    }
    const MinimumZonePlane mz = FitPlaneMinimumZone(x, y, z);
    const double independent = NestedSearchPlaneZone(x, y, z);
    EXPECT_NEAR(mz.width, independent, 1e-3) << "seed " << seed;
    EXPECT_LE(mz.width, independent + 1e-9) << "seed " << seed;
  }
}

TEST(PlaneFit, MinimumZoneOfAnXOnlyFormEqualsTheLineZone) {
  // z = g(x) on a full grid: the minimum-zone planes contain the y direction, so the flatness
  // equals the minimum-zone straightness of (x, g(x)) (a different exact algorithm).
  for (unsigned seed : {51u, 52u, 53u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 1.0);
    std::vector<double> gx, gz;
    for (int i = 0; i < 25; ++i) {
      gx.push_back(-100.0 + 8.0 * i);
      gz.push_back(0.05 * gx.back() + noise(rng));
    }
    std::vector<double> x, y, z;
    for (int j = 0; j < 9; ++j) {
      for (std::size_t i = 0; i < gx.size(); ++i) {
        x.push_back(gx[i]);
        y.push_back(-40.0 + 10.0 * j);
        z.push_back(gz[i] - 0.02 * y.back());
      }
    }
    const MinimumZonePlane mz = FitPlaneMinimumZone(x, y, z);
    const MinimumZoneLine ml = FitLineMinimumZone(gx, gz);
    EXPECT_NEAR(mz.width, ml.width, 1e-9 * (1.0 + ml.width)) << "seed " << seed;
    EXPECT_NEAR(mz.centre.slope_y, -0.02, 1e-9);
  }
}

TEST(PlaneFit, CollinearPositionsAreNotObservable) {
  const std::vector<double> x{0, 1, 2, 3}, y{0, 2, 4, 6}, z{0, 1, 0, 1};
  EXPECT_THROW(FitPlaneLeastSquares(x, y, z), NotObservable);
  EXPECT_THROW(FitPlaneMinimumZone(x, y, z), NotObservable);
}

}  // namespace
}  // namespace km::geometry
