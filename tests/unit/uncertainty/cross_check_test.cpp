// The first-order GUM beside Monte Carlo ([JCGM 101] §8): a linear model agrees (both give
// √Σ(c_i·u_i)² exactly in the limit; 10^5 draws leave about 0.3 % of sampling error on u, so
// 5 % is never crossed), while nonlinear figures are marked: Y = X² at X = 0 (first order 0,
// Monte Carlo √2·u²) and the range of two equal readings |X1 − X2| (first order: the
// derivative of |·| at 0 by central differences is 0; Monte Carlo √(1 − 2/π)·√2·u).
#include "analysis/uncertainty/cross_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <span>

#include "analysis/core/errors.h"

namespace {

using km::uncertainty::CrossCheckGum;
using km::uncertainty::FirstOrderUncertainties;
using km::uncertainty::McInput;
using km::uncertainty::McOptions;
using km::uncertainty::PropagateMonteCarlo;

McOptions Options() {
  McOptions o;
  o.draws = 100'000;
  o.seed = 7;
  o.budget_draws = 0;
  return o;
}

TEST(GumCrossCheck, ALinearModelAgreesWithMonteCarlo) {
  const auto model = [](std::span<const double> x, std::span<double> y) {
    y[0] = 3.0 * x[0] - 2.0 * x[1];
    y[1] = x[0] + x[1];
  };
  const std::vector<McInput> in = {McInput::Normal("a", 1.0, 0.2),
                                   McInput::Rectangular("b", -1.0, 1.0)};
  const double ub = 2.0 / std::sqrt(12.0);
  const auto first = FirstOrderUncertainties(model, in, 2);
  EXPECT_NEAR(first[0], std::hypot(3.0 * 0.2, 2.0 * ub), 1e-9);
  EXPECT_NEAR(first[1], std::hypot(0.2, ub), 1e-9);
  const auto mc = PropagateMonteCarlo(model, in, 2, Options());
  const auto checks = CrossCheckGum(model, in, mc, {"y0", "y1"});
  ASSERT_EQ(checks.size(), 2u);
  for (const auto& c : checks) {
    EXPECT_FALSE(c.differs) << c.name << " " << c.relative_difference;
    EXPECT_LT(c.relative_difference, 0.02) << c.name;
  }
}

TEST(GumCrossCheck, NonlinearFiguresAreMarked) {
  const double u = 0.5;
  const auto model = [](std::span<const double> x, std::span<double> y) {
    y[0] = x[0] * x[0];
    y[1] = std::abs(x[0] - x[1]);
  };
  const std::vector<McInput> in = {McInput::Normal("x1", 0.0, u), McInput::Normal("x2", 0.0, u)};
  const auto mc = PropagateMonteCarlo(model, in, 2, Options());
  const auto checks = CrossCheckGum(model, in, mc, {"square", "range"});
  EXPECT_EQ(checks[0].u_gum, 0.0);
  EXPECT_NEAR(checks[0].u_mc, std::sqrt(2.0) * u * u, 0.02 * std::sqrt(2.0) * u * u);
  EXPECT_TRUE(checks[0].differs);
  const double range_u = std::sqrt(1.0 - 2.0 / std::numbers::pi) * std::sqrt(2.0) * u;
  EXPECT_NEAR(checks[1].u_mc, range_u, 0.02 * range_u);
  EXPECT_TRUE(checks[1].differs);
}

TEST(GumCrossCheck, NamesMustMatchTheOutputs) {
  const auto model = [](std::span<const double> x, std::span<double> y) { y[0] = x[0]; };
  const std::vector<McInput> in = {McInput::Normal("x", 0.0, 1.0)};
  const auto mc = PropagateMonteCarlo(model, in, 1, Options());
  EXPECT_THROW(CrossCheckGum(model, in, mc, {"a", "b"}), km::InvalidInput);
}

}  // namespace
