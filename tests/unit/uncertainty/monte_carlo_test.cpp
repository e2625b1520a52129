// Monte Carlo propagation ([JCGM 101]) against closed forms. Tolerances are stated per check
// from the sampling error of M draws: the relative standard error of u is about 1/√(2M), that
// of a 2.5 % or 97.5 % quantile √(0.025·0.975/M)/f(quantile), f the output's density.
#include <gtest/gtest.h>

#include <cmath>
#include <span>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/uncertainty/gum.h"
#include "analysis/uncertainty/monte_carlo.h"

namespace {

using km::uncertainty::McInput;
using km::uncertainty::McOptions;
using km::uncertainty::PropagateMonteCarlo;

// Y = Σ c_i X_i, and as a second output 2Y − 1 (a model of several outputs).
const std::vector<double> kLinearCoefficients = {1.0, -2.0, 0.5, 3.0};

void LinearModel(std::span<const double> x, std::span<double> y) {
  double s = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) s += kLinearCoefficients[i] * x[i];
  y[0] = s;
  y[1] = 2.0 * s - 1.0;
}

std::vector<McInput> LinearInputs() {
  return {McInput::Normal("x1", 1.0, 0.1), McInput::Normal("x2", 2.0, 0.2),
          McInput::Normal("x3", -1.0, 0.4), McInput::Normal("x4", 0.5, 0.05)};
}

// u of Y by the law of propagation (exact for a linear model).
double LinearGumU() {
  std::vector<double> u;
  for (const auto& in : LinearInputs()) u.push_back(in.u);
  return km::uncertainty::CombinedStandardUncertainty(kLinearCoefficients, u);
}

TEST(MonteCarloLinear, NormalInputsAgreeWithTheGum) {
  McOptions o;
  o.draws = 1'000'000;
  o.seed = 11;
  const auto r = PropagateMonteCarlo(LinearModel, LinearInputs(), 2, o);
  const double u = LinearGumU();
  const double y = 1.0 - 4.0 - 0.5 + 1.5;
  ASSERT_EQ(r.outputs.size(), 2u);
  // u within 1 % of the GUM's (standard error 0.07 % at M = 10⁶).
  EXPECT_NEAR(r.outputs[0].u, u, 0.01 * u);
  EXPECT_NEAR(r.outputs[1].u, 2.0 * u, 0.02 * u);
  // Mean within 0.01 u (standard error 0.001 u).
  EXPECT_NEAR(r.outputs[0].mean, y, 0.01 * u);
  // Interval y ± 1.96 u, ends within 0.015 u (standard error 0.003 u); U = 2u.
  EXPECT_NEAR(r.outputs[0].low, y - 1.95996 * u, 0.015 * u);
  EXPECT_NEAR(r.outputs[0].high, y + 1.95996 * u, 0.015 * u);
  EXPECT_DOUBLE_EQ(r.outputs[0].U, 2.0 * r.outputs[0].u);
  EXPECT_EQ(r.draws, 1'000'000u);
}

TEST(MonteCarloLinear, BudgetByOneInputAtATime) {
  McOptions o;
  o.draws = 20'000;
  o.budget_draws = 40'000;
  const auto inputs = LinearInputs();
  const auto r = PropagateMonteCarlo(LinearModel, inputs, 2, o);
  // σ of Y with X_i alone is |c_i| u_i; within 2 % (standard error 0.35 % at 40 000 draws).
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const double truth = std::abs(kLinearCoefficients[i]) * inputs[i].u;
    EXPECT_NEAR(r.outputs[0].budget[i], truth, 0.02 * truth) << inputs[i].name;
    EXPECT_NEAR(r.outputs[1].budget[i], 2.0 * truth, 0.04 * truth) << inputs[i].name;
  }
}

TEST(MonteCarloRectangular, SumOfTwoEqualRectangularsIsTriangular) {
  // X1, X2 ~ R(−a, a): Y = X1 + X2 is the triangle on [−2a, 2a], u = a √(2/3), and the 95 %
  // interval ±2a (1 − √0.05) = ±1.55279 a. Tolerance 0.01 a on the ends (standard error
  // 0.0014 a), 1 % on u.
  const double a = 3.0;
  const auto sum = [](std::span<const double> x, std::span<double> y) { y[0] = x[0] + x[1]; };
  McOptions o;
  o.seed = 5;
  o.budget_draws = 0;
  const auto r = PropagateMonteCarlo(
      sum, {McInput::Rectangular("x1", -a, a), McInput::Rectangular("x2", -a, a)}, 1, o);
  EXPECT_NEAR(r.outputs[0].u, a * std::sqrt(2.0 / 3.0), 0.01 * a * std::sqrt(2.0 / 3.0));
  const double half = 2.0 * a * (1.0 - std::sqrt(0.05));
  EXPECT_NEAR(r.outputs[0].low, -half, 0.01 * a);
  EXPECT_NEAR(r.outputs[0].high, half, 0.01 * a);
  EXPECT_TRUE(r.outputs[0].budget.empty());
}

TEST(MonteCarloTriangular, TriangularInputHasItsQuantiles) {
  // X ~ symmetric triangle of half-width a: u = a/√6, 95 % interval ±a (1 − √0.05).
  const double a = 2.0;
  const auto id = [](std::span<const double> x, std::span<double> y) { y[0] = x[0]; };
  McOptions o;
  o.budget_draws = 0;
  const auto r = PropagateMonteCarlo(id, {McInput::Triangular("x", 1.0, a)}, 1, o);
  EXPECT_NEAR(r.outputs[0].u, a / std::sqrt(6.0), 0.01 * a / std::sqrt(6.0));
  EXPECT_NEAR(r.outputs[0].high - 1.0, a * (1.0 - std::sqrt(0.05)), 0.005 * a);
  EXPECT_NEAR(r.outputs[0].low - 1.0, -a * (1.0 - std::sqrt(0.05)), 0.005 * a);
}

TEST(MonteCarloNonlinear, SquareOfAZeroMeanNormal) {
  // Y = X², X ~ N(0, σ²): the first-order GUM gives u_c = 0 (c = 2x = 0 at the estimate); by
  // Monte Carlo Y = σ² χ²₁: mean σ², u = √2 σ², 95 % interval [σ² χ²₁(0.025), σ² χ²₁(0.975)]
  // = σ² [0.000982069, 5.023886]. Tolerances: 5 % on the lower end (standard error 1.3 %, the
  // density is steep there), 1 % on the upper (0.2 %), 1 % on the mean and u.
  const double sigma = 2.0;
  const double s2 = sigma * sigma;
  const auto gum = km::uncertainty::PropagateGum(
      [](const std::vector<double>& x) { return x[0] * x[0]; }, {{"x", 0.0, sigma}});
  EXPECT_NEAR(gum.u_c, 0.0, 1e-9);
  const auto square = [](std::span<const double> x, std::span<double> y) { y[0] = x[0] * x[0]; };
  McOptions o;
  o.seed = 3;
  const auto r = PropagateMonteCarlo(square, {McInput::Normal("x", 0.0, sigma)}, 1, o);
  EXPECT_NEAR(r.outputs[0].mean, s2, 0.01 * s2);
  EXPECT_NEAR(r.outputs[0].u, std::sqrt(2.0) * s2, 0.01 * std::sqrt(2.0) * s2);
  EXPECT_NEAR(r.outputs[0].low, 0.000982069 * s2, 0.05 * 0.000982069 * s2);
  EXPECT_NEAR(r.outputs[0].high, 5.023886 * s2, 0.01 * 5.023886 * s2);
}

TEST(MonteCarloSeed, SameSeedSameResultOtherSeedOther) {
  McOptions o;
  o.draws = 50'000;
  o.seed = 42;
  const auto a = PropagateMonteCarlo(LinearModel, LinearInputs(), 2, o);
  const auto b = PropagateMonteCarlo(LinearModel, LinearInputs(), 2, o);
  for (std::size_t j = 0; j < 2; ++j) {
    EXPECT_EQ(a.outputs[j].mean, b.outputs[j].mean);
    EXPECT_EQ(a.outputs[j].u, b.outputs[j].u);
    EXPECT_EQ(a.outputs[j].low, b.outputs[j].low);
    EXPECT_EQ(a.outputs[j].high, b.outputs[j].high);
    EXPECT_EQ(a.outputs[j].budget, b.outputs[j].budget);
  }
  EXPECT_EQ(a.seed, 42u);
  o.seed = (std::uint64_t{1} << 40) + 42;  // differs from 42 only above the low 32 bits
  const auto c = PropagateMonteCarlo(LinearModel, LinearInputs(), 2, o);
  EXPECT_NE(a.outputs[0].mean, c.outputs[0].mean);
}

TEST(MonteCarloAdaptive, StopsWhenStableToTheStatedDigits) {
  // u = 1.5 to 3 significant digits: δ = 0.005 ([JCGM 101] §7.9.2). The procedure stops when
  // twice the standard deviation of every batch average is at most δ, so the results are within
  // about δ of the truth: u within δ, the interval ends within 2δ.
  const auto id = [](std::span<const double> x, std::span<double> y) { y[0] = x[0]; };
  McOptions o;
  o.adaptive = true;
  o.significant_digits = 3;
  o.budget_draws = 0;
  const auto r = PropagateMonteCarlo(id, {McInput::Normal("x", 10.0, 1.5)}, 1, o);
  EXPECT_TRUE(r.converged);
  EXPECT_DOUBLE_EQ(r.tolerance, 0.005);
  EXPECT_EQ(r.draws % o.batch, 0u);
  EXPECT_GE(r.draws, 2 * o.batch);
  EXPECT_LT(r.draws, o.max_draws);
  EXPECT_NEAR(r.outputs[0].u, 1.5, 0.005);
  EXPECT_NEAR(r.outputs[0].high, 10.0 + 1.95996 * 1.5, 0.01);
  // Fewer digits, fewer draws; an unreachable tolerance stops at max_draws, not converged.
  o.significant_digits = 1;
  const auto coarse = PropagateMonteCarlo(id, {McInput::Normal("x", 10.0, 1.5)}, 1, o);
  EXPECT_TRUE(coarse.converged);
  EXPECT_LT(coarse.draws, r.draws);
  o.significant_digits = 6;
  o.max_draws = 50'000;
  const auto capped = PropagateMonteCarlo(id, {McInput::Normal("x", 10.0, 1.5)}, 1, o);
  EXPECT_FALSE(capped.converged);
  EXPECT_EQ(capped.draws, 50'000u);
}

TEST(MonteCarloHelpers, IntervalTolerancesAndErrors) {
  // M = 40, p = 0.95: q = 38, r = 1: [y_(1), y_(39)] ([JCGM 101] §7.7).
  std::vector<double> draws;
  for (int i = 40; i >= 1; --i) draws.push_back(i);
  const auto [low, high] = km::uncertainty::SymmetricCoverageInterval(draws, 0.95);
  EXPECT_EQ(low, 1.0);
  EXPECT_EQ(high, 39.0);
  EXPECT_DOUBLE_EQ(km::uncertainty::NumericalTolerance(0.0123, 2), 0.0005);
  EXPECT_DOUBLE_EQ(km::uncertainty::NumericalTolerance(1.5, 3), 0.005);
  const auto id = [](std::span<const double> x, std::span<double> y) { y[0] = x[0]; };
  McOptions few;
  few.draws = 10;  // fewer than 1/(1 − p) = 20
  EXPECT_THROW(PropagateMonteCarlo(id, {McInput::Normal("x", 0.0, 1.0)}, 1, few), km::InvalidInput);
  EXPECT_THROW(PropagateMonteCarlo(id, {McInput::Normal("x", 0.0, -1.0)}, 1), km::InvalidInput);
}

}  // namespace
