// Brent's minimisation in a bracket (analysis/core/minimize_1d.h): minima known in closed form,
// smooth ones found to the tolerance in far fewer evaluations than a golden-section search to
// the same resolution needs (log(tol / width) / log 0.618), a kink and a minimum at the edge of
// the bracket found by its golden steps, and the bound on evaluations kept.
#include "analysis/core/minimize_1d.h"

#include <gtest/gtest.h>

#include <cmath>

namespace km {
namespace {

int GoldenSectionEvaluations(double width, double tol) {
  return 2 + static_cast<int>(
                 std::ceil(std::log(tol / width) / std::log(0.5 * (std::sqrt(5.0) - 1.0))));
}

TEST(BrentMinimize, SmoothMinimaToTheToleranceInFewEvaluations) {
  struct Case {
    double (*f)(double);
    double a, b, truth;
  };
  const Case cases[] = {
      {[](double x) { return (x - 0.3) * (x - 0.3) + 2.0; }, -1.0, 2.0, 0.3},
      {[](double x) { return x - std::log(x); }, 0.1, 10.0, 1.0},
      {[](double x) { return std::exp(x) - 2.0 * x; }, -3.0, 3.0, std::log(2.0)},
      {[](double x) { return -std::sin(x); }, 0.0, 3.0, 0.5 * M_PI},
      {[](double x) { return std::cosh(3.0 * (x + 0.61)); }, -2.0, 0.25, -0.61},
  };
  const double tol = 1e-7;
  for (const auto& c : cases) {
    const Minimum1d m = BrentMinimize(c.f, c.a, c.b, tol);
    EXPECT_NEAR(m.x, c.truth, 3.0 * tol) << c.truth;
    EXPECT_DOUBLE_EQ(m.fx, c.f(m.x));
    EXPECT_LT(m.evaluations, GoldenSectionEvaluations(c.b - c.a, tol) / 2) << c.truth;
  }
}

TEST(BrentMinimize, AKinkAndAnEdgeAreFoundByGoldenSteps) {
  const double tol = 1e-6;
  const Minimum1d kink = BrentMinimize([](double x) { return std::abs(x - 0.7); }, 0.0, 1.0, tol);
  EXPECT_NEAR(kink.x, 0.7, 3.0 * tol);
  const Minimum1d edge = BrentMinimize([](double x) { return x; }, 0.0, 1.0, tol);
  EXPECT_LT(edge.x, 3.0 * tol);
  EXPECT_GT(edge.x, 0.0);  // never evaluated at the bracket's ends
  // A flat quartic minimum: parabolas converge slowly there, the bound holds.
  const Minimum1d flat =
      BrentMinimize([](double x) { return std::pow(x - 1.0, 4); }, 0.0, 3.0, 1e-9, 40);
  EXPECT_LE(flat.evaluations, 40);
  EXPECT_NEAR(flat.x, 1.0, 1e-2);
}

}  // namespace
}  // namespace km
