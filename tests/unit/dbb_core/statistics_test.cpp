// The discovery engine's distributions and noise floor (analysis/core/statistics.h) against
// closed forms and an independent quadrature.
#include "analysis/core/statistics.h"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace km {
namespace {

TEST(Statistics, FUpperTailMatchesClosedForms) {
  // d1 = 2: P(F > f) = (1 + 2f/d2)^(−d2/2); d2 = 2: P = 1 − (d1 f / (2 + d1 f))^(d1/2).
  for (double d2 : {3.0, 10.0, 57.0, 1000.0, 14391.0}) {
    for (double f : {0.01, 0.5, 1.0, 3.0, 10.0, 60.0, 400.0}) {
      const double log_p = -0.5 * d2 * std::log1p(2.0 * f / d2);
      EXPECT_NEAR(LogFUpperTail(f, 2.0, d2), log_p, 1e-9 * std::max(1.0, std::abs(log_p)))
          << "d2 " << d2 << " f " << f;
    }
  }
  for (double d1 : {1.0, 3.0, 8.0}) {
    for (double f : {0.05, 0.7, 2.0, 9.0, 150.0}) {
      const double p = 1.0 - std::pow(d1 * f / (2.0 + d1 * f), 0.5 * d1);
      EXPECT_NEAR(std::exp(LogFUpperTail(f, d1, 2.0)), p, 1e-12) << "d1 " << d1 << " f " << f;
    }
  }
  // d1 = 1, d2 → ∞: F = χ²₁, P = erfc(√(f/2)); at d2 = 1e7 the t-vs-normal tail differs by
  // O(f²/(4 d2)) relative (1.6e-5 at f = 25), hence the tolerance.
  for (double f : {0.3, 2.0, 9.0, 25.0}) {
    const double p = std::erfc(std::sqrt(0.5 * f));
    EXPECT_NEAR(std::exp(LogFUpperTail(f, 1.0, 1e7)), p, (1e-6 + f * f / 1e7) * p) << "f " << f;
  }
  EXPECT_EQ(LogFUpperTail(0.0, 1.0, 10.0), 0.0);
}

TEST(Statistics, IncompleteBetaMatchesQuadrature) {
  // Independent: Simpson integration of t^(a−1)(1−t)^(b−1) / B(a, b) (a, b ≥ 1: smooth).
  for (double a : {1.0, 2.5, 7.0}) {
    for (double b : {1.0, 1.5, 4.0}) {
      for (double x : {0.1, 0.45, 0.8, 0.97}) {
        const int n = 20000;
        const double h = x / n;
        double s = 0.0;
        for (int i = 0; i <= n; ++i) {
          const double t = i * h;
          const double w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
          s += w * std::pow(t, a - 1.0) * std::pow(1.0 - t, b - 1.0);
        }
        s *= h / 3.0;
        const double beta = std::exp(std::lgamma(a) + std::lgamma(b) - std::lgamma(a + b));
        EXPECT_NEAR(RegularisedIncompleteBeta(a, b, x), s / beta, 1e-8)
            << a << " " << b << " " << x;
      }
    }
  }
}

TEST(Statistics, RobustNoiseFloorIgnoresStepsAndSmoothSignal) {
  for (unsigned seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> g(0.0, 0.3);
    std::vector<std::vector<double>> r(2);
    for (auto& tr : r) {
      for (int i = 0; i < 3600; ++i) {
        const double th = i * 0.1 * std::numbers::pi / 180.0;
        // 10 µm second harmonic and two 4 µm steps (backlash-like) on top of the noise.
        tr.push_back(10.0 * std::sin(2.0 * th) + (i > 900 && i < 2700 ? 4.0 : 0.0) + g(rng));
      }
    }
    EXPECT_NEAR(RobustDiffNoiseUm(r), 0.3, 0.3 * 0.05) << "seed " << seed;
  }
}

}  // namespace
}  // namespace km
