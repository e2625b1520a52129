#include "analysis/geometry/circle_fit.h"

#include <Eigen/Dense>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>

#include "analysis/core/cpu.h"
#include "analysis/core/errors.h"
#include "analysis/geometry/circle_sums.h"

namespace km::geometry {
namespace {

std::vector<Eigen::Vector2d> Trace(double cx, double cy, double r, int n,
                                   const std::function<double(double)>& form, double noise,
                                   unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> nd(0.0, noise);
  std::vector<Eigen::Vector2d> p;
  for (int i = 0; i < n; ++i) {
    const double th = 2 * std::numbers::pi * i / n;
    const double rr = r + (form ? form(th) : 0.0) + (noise > 0 ? nd(rng) : 0.0);
    p.emplace_back(cx + rr * std::cos(th), cy + rr * std::sin(th));
  }
  return p;
}

// Independent check: minimise the variance of the distances over the centre by Newton's method
// with finite-difference derivatives (R0 is then the mean distance).
Circle IndependentFit(const std::vector<Eigen::Vector2d>& p, Eigen::Vector2d c) {
  auto cost = [&](const Eigen::Vector2d& q) {
    double m = 0;
    for (const auto& x : p) m += (x - q).norm();
    m /= static_cast<double>(p.size());
    double s = 0;
    for (const auto& x : p) s += std::pow((x - q).norm() - m, 2);
    return s;
  };
  const double h = 1e-3;
  for (int it = 0; it < 50; ++it) {
    Eigen::Vector2d g;
    Eigen::Matrix2d hess;
    for (int a = 0; a < 2; ++a) {
      Eigen::Vector2d e = Eigen::Vector2d::Zero();
      e(a) = h;
      g(a) = (cost(c + e) - cost(c - e)) / (2 * h);
      for (int b = 0; b < 2; ++b) {
        Eigen::Vector2d f = Eigen::Vector2d::Zero();
        f(b) = h;
        hess(a, b) =
            (cost(c + e + f) - cost(c + e - f) - cost(c - e + f) + cost(c - e - f)) / (4 * h * h);
      }
    }
    const Eigen::Vector2d step = hess.ldlt().solve(-g);
    c += step;
    if (step.norm() < 1e-9) break;
  }
  double m = 0;
  for (const auto& x : p) m += (x - c).norm();
  return Circle{c, m / static_cast<double>(p.size())};
}

TEST(CircleFit, NoiseFreeCircleIsRecoveredExactly) {
  // µm units, as the DBB analysis uses them: R = 150 mm.
  const auto p = Trace(12.345, -6.789, 150000.0, 3600, nullptr, 0.0, 1);
  const auto fit = FitCircleLeastSquares(p);
  EXPECT_NEAR(fit.circle.centre.x(), 12.345, 1e-6);
  EXPECT_NEAR(fit.circle.centre.y(), -6.789, 1e-6);
  EXPECT_NEAR(fit.circle.radius, 150000.0, 1e-6);
  EXPECT_LT(fit.rms_residual, 1e-6);
}

TEST(CircleFit, AgreesWithIndependentComputationOnFormErrors) {
  // Elliptic + trefoil + 5th-order form error and a centre offset: the least-squares circle
  // of the two algorithms must agree to 0.001 µm.
  auto form = [](double th) {
    return 4.0 * std::cos(2 * th - 0.3) + 1.5 * std::cos(3 * th + 1.0) + 0.7 * std::sin(5 * th);
  };
  for (unsigned seed : {1u, 2u, 3u}) {
    const auto p = Trace(-3.0 * seed, 7.5, 100000.0 + seed, 1440, form, 0.0, seed);
    const auto fit = FitCircleLeastSquares(p);
    const auto ind = IndependentFit(p, Eigen::Vector2d(50.0, -50.0));
    EXPECT_NEAR(fit.circle.centre.x(), ind.centre.x(), 1e-3);
    EXPECT_NEAR(fit.circle.centre.y(), ind.centre.y(), 1e-3);
    EXPECT_NEAR(fit.circle.radius, ind.radius, 1e-3);
  }
}

TEST(CircleFit, RecoversCentreWithinThreeSigmaOfNoise) {
  const double sigma = 0.5;
  const int n = 3600;
  // Standard deviation of the centre estimate: σ·sqrt(2/n); of the radius: σ/sqrt(n).
  const double sc = sigma * std::sqrt(2.0 / n), sr = sigma / std::sqrt(n);
  for (unsigned seed = 10; seed < 20; ++seed) {
    const auto p = Trace(4.0, -2.0, 150000.0 + 3.0, n, nullptr, sigma, seed);
    const auto fit = FitCircleLeastSquares(p);
    EXPECT_LT(std::abs(fit.circle.centre.x() - 4.0), 3 * sc) << "seed " << seed;
    EXPECT_LT(std::abs(fit.circle.centre.y() + 2.0), 3 * sc) << "seed " << seed;
    EXPECT_LT(std::abs(fit.circle.radius - 150003.0), 3 * sr) << "seed " << seed;
    EXPECT_NEAR(fit.rms_residual, sigma, 0.05);
  }
}

// At the fitted circle the cost is stationary to rounding: the Gauss–Newton step computed there
// in extended precision, point by point, is below 1e-10 µm (a few units in the last place of the
// radius; 2·10⁻⁶ of the centre's σ at the least noise here), also for data so clean that the
// last steps cannot be judged by the cost itself.
TEST(CircleFit, TheMinimumIsReachedToRounding) {
  for (double noise : {0.5, 0.1, 0.002}) {
    for (unsigned seed = 30; seed < 34; ++seed) {
      const auto p = Trace(4.0, -3.0, 150000.0, 3600, nullptr, noise, seed);
      const auto fit = FitCircleLeastSquares(p);
      Eigen::Matrix<long double, 3, 3> jtj = Eigen::Matrix<long double, 3, 3>::Zero();
      Eigen::Matrix<long double, 3, 1> jtd = Eigen::Matrix<long double, 3, 1>::Zero();
      for (const auto& q : p) {
        const long double vx = static_cast<long double>(q.x()) - fit.circle.centre.x();
        const long double vy = static_cast<long double>(q.y()) - fit.circle.centre.y();
        const long double dist = std::sqrt(vx * vx + vy * vy);
        const Eigen::Matrix<long double, 3, 1> j(-vx / dist, -vy / dist, -1.0L);
        jtj += j * j.transpose();
        jtd += j * (dist - fit.circle.radius);
      }
      const Eigen::Matrix<long double, 3, 1> step = -jtj.ldlt().solve(jtd);
      EXPECT_LT(static_cast<double>(step.norm()), 1e-10) << "noise " << noise << " seed " << seed;
    }
  }
}

// Short noisy arcs (a flat valley of centre against radius): the fit still ends at the minimum,
// where the decrease a Gauss–Newton step computed in extended precision predicts is below 10⁻⁹
// of the cost (a cost ~10 orders of magnitude above its rounding), and near the truth.
TEST(CircleFit, ShortNoisyArcsEndAtTheMinimum) {
  for (const double arc_deg : {40.0, 90.0, 200.0}) {
    for (unsigned seed = 50; seed < 53; ++seed) {
      std::mt19937 rng(seed);
      std::normal_distribution<double> nd(0.0, 0.1);
      std::vector<Eigen::Vector2d> p;
      for (int i = 0; i < 900; ++i) {
        const double th = 0.3 + arc_deg * std::numbers::pi / 180.0 * i / 899.0;
        p.emplace_back(-4.0 + (100000.0 + nd(rng)) * std::cos(th),
                       2.5 + (100000.0 + nd(rng)) * std::sin(th));
      }
      const auto fit = FitCircleLeastSquares(p);
      Eigen::Matrix<long double, 3, 3> jtj = Eigen::Matrix<long double, 3, 3>::Zero();
      Eigen::Matrix<long double, 3, 1> jtd = Eigen::Matrix<long double, 3, 1>::Zero();
      long double cost = 0.0L;
      for (const auto& q : p) {
        const long double vx = static_cast<long double>(q.x()) - fit.circle.centre.x();
        const long double vy = static_cast<long double>(q.y()) - fit.circle.centre.y();
        const long double dist = std::sqrt(vx * vx + vy * vy);
        const long double d = dist - fit.circle.radius;
        const Eigen::Matrix<long double, 3, 1> j(-vx / dist, -vy / dist, -1.0L);
        jtj += j * j.transpose();
        jtd += j * d;
        cost += d * d;
      }
      const long double decrease = 0.5L * jtd.dot(jtj.ldlt().solve(jtd));
      EXPECT_LT(static_cast<double>(decrease / cost), 1e-9) << arc_deg << "° seed " << seed;
      EXPECT_NEAR(fit.circle.radius, 100000.0, 2.0) << arc_deg << "° seed " << seed;
    }
  }
}

TEST(CircleFit, PartialArcFarFromOrigin) {
  std::vector<Eigen::Vector2d> p;
  for (int i = 0; i < 100; ++i) {
    const double th = 0.2 + 1.0 * i / 99;
    p.emplace_back(1e5 + 50.0 * std::cos(th), -2e5 + 50.0 * std::sin(th));
  }
  const auto fit = FitCircleLeastSquares(p);
  EXPECT_NEAR(fit.circle.radius, 50.0, 1e-6);
  EXPECT_NEAR(fit.circle.centre.x(), 1e5, 1e-6);
}

TEST(CircleFit, RejectsDegenerateInput) {
  EXPECT_THROW(FitCircleLeastSquares({{0, 0}, {1, 1}}), InvalidInput);
  EXPECT_THROW(FitCircleLeastSquares({{0, 0}, {1, 1}, {2, 2}, {3, 3}}), InvalidInput);
  EXPECT_THROW(FitCircleLeastSquares({{1, 1}, {1, 1}, {1, 1}}), InvalidInput);
}

// The four-lane sums of a Gauss–Newton step against the same sums in long double, for lengths
// that leave every tail (0–3 points) and a point at the centre (no direction: left out of all but
// the cost); the cost alone equals the step's cost bit for bit.
TEST(CircleFit, FusedSumsAreTheStepsSums) {
  if (!CpuHasAvx2Fma()) GTEST_SKIP() << "no AVX2 and FMA: the fit sums with Eigen";
  std::mt19937 rng(5);
  std::normal_distribution<double> nd(0.0, 3.0);
  for (const int n : {0, 1, 3, 4, 7, 1001, 3602}) {
    std::vector<double> x, y;
    for (int i = 0; i < n; ++i) {
      const double th = 0.37 * i;
      x.push_back(150e3 * std::cos(th) + nd(rng) + 12.0);
      y.push_back(150e3 * std::sin(th) + nd(rng) - 7.0);
    }
    if (n > 2) x[2] = 12.5, y[2] = -6.25;  // exactly at the centre below
    const double cx = 12.5, cy = -6.25, r = 150e3 + 1.5;
    long double e[10] = {};
    double dmax = 0.0;
    for (int i = 0; i < n; ++i) {
      const long double vx = x[i] - cx, vy = y[i] - cy, dist = std::sqrt(vx * vx + vy * vy);
      e[9] += (dist - r) * (dist - r);
      dmax = std::max(dmax, static_cast<double>(std::abs(dist - r)));
      if (!(dist > 0)) continue;
      const long double ux = vx / dist, uy = vy / dist, d = dist - r;
      const long double add[9] = {ux * ux, ux * uy, uy * uy, ux, uy, 1, -ux * d, -uy * d, -d};
      for (int k = 0; k < 9; ++k) e[k] += add[k];
    }
    internal::CircleSums f;
    ASSERT_TRUE(internal::CircleSumsFused(x.data(), y.data(), n, cx, cy, r, f));
    const double got[10] = {f.sxx, f.sxy, f.syy, f.sx, f.sy, f.n, f.bx, f.by, f.b, f.ss};
    for (int k = 0; k < 10; ++k) {
      // A distance in double is rounded to about ε·R (3·10⁻¹¹ µm here), which the sums weighted
      // by the residual d carry; the directions are rounded to ε.
      const double er = 1e-10 * (n + 1);
      const double scale = k < 6 ? 1e-12 * (n + 1) : (k < 9 ? er : 2.0 * er * (1.0 + dmax));
      EXPECT_NEAR(got[k], static_cast<double>(e[k]), scale) << "n " << n << " sum " << k;
    }
    double cost = -1.0;
    ASSERT_TRUE(internal::CircleCostFused(x.data(), y.data(), n, cx, cy, r, cost));
    EXPECT_EQ(cost, f.ss) << n;
  }
}

}  // namespace
}  // namespace km::geometry
