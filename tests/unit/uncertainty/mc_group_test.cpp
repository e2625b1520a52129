// Monte Carlo inputs standing for groups of independent draws (monte_carlo.h McInput::count):
// the sum of n independent N(0, σ²) readings has σ·√n, their range the distribution of a range;
// one budget entry for the group; the same seed gives the same result.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <span>

#include "analysis/core/errors.h"
#include "analysis/uncertainty/monte_carlo.h"

namespace {

using km::uncertainty::McInput;
using km::uncertainty::McOptions;
using km::uncertainty::PropagateMonteCarlo;

void SumAndShift(std::span<const double> x, std::span<double> y) {
  double s = 0.0;
  for (std::size_t i = 0; i + 1 < x.size(); ++i) s += x[i];
  y[0] = s;
  y[1] = x.back();
}

TEST(McGroup, SumOfIndependentReadings) {
  McOptions o;
  o.draws = 20'000;
  o.budget_draws = 5'000;
  const std::vector<McInput> in{McInput::NormalGroup("readings", 0.0, 0.5, 100),
                                McInput::Normal("shift", 2.0, 0.3)};
  EXPECT_EQ(km::uncertainty::DrawSize(in), 101u);
  EXPECT_EQ(km::uncertainty::InputOffset(in, 1), 100u);
  const auto r = PropagateMonteCarlo(SumAndShift, in, 2, o);
  // σ of the sum 0.5·√100 = 5; the standard error of u at M = 2·10⁴ is 0.5 %: 3 % is > 5σ.
  EXPECT_NEAR(r.outputs[0].u, 5.0, 0.15);
  EXPECT_NEAR(r.outputs[0].mean, 0.0, 0.15);
  EXPECT_NEAR(r.outputs[1].u, 0.3, 0.01);
  EXPECT_NEAR(r.outputs[1].mean, 2.0, 0.01);
  ASSERT_EQ(r.outputs[0].budget.size(), 2u);  // one entry for the group
  EXPECT_NEAR(r.outputs[0].budget[0], 5.0, 0.3);
  EXPECT_EQ(r.outputs[0].budget[1], 0.0);
  EXPECT_NEAR(r.outputs[1].budget[1], 0.3, 0.02);
  const auto again = PropagateMonteCarlo(SumAndShift, in, 2, o);
  EXPECT_EQ(again.outputs[0].u, r.outputs[0].u);
}

TEST(McGroup, NormalDrawsHaveNormalTails) {
  // One group of 10⁶ draws in one evaluation: the fraction beyond 1.96σ and 3σ (the ziggurat's
  // layers and its tail).
  const std::size_t n = 1'000'000;
  double beyond2 = 0.0, beyond3 = 0.0, m4 = 0.0;
  auto model = [&](std::span<const double> x, std::span<double> y) {
    beyond2 = static_cast<double>(
        std::count_if(x.begin(), x.end(), [](double v) { return std::abs(v) > 1.96; }));
    beyond3 = static_cast<double>(
        std::count_if(x.begin(), x.end(), [](double v) { return std::abs(v) > 3.0; }));
    m4 = 0.0;
    for (double v : x) m4 += v * v * v * v;
    y[0] = x[0];
  };
  McOptions o;
  o.draws = 20;
  o.budget_draws = 0;
  (void)PropagateMonteCarlo(model, {McInput::NormalGroup("z", 0.0, 1.0, n)}, 1, o);
  EXPECT_NEAR(beyond2 / n, 0.0500, 0.0010);
  EXPECT_NEAR(beyond3 / n, 0.0027, 0.0003);
  EXPECT_NEAR(m4 / n, 3.0, 0.05);  // kurtosis of the normal
}

TEST(McGroup, ZeroCountIsRefused) {
  EXPECT_THROW(McInput::NormalGroup("z", 0.0, 1.0, 0), km::InvalidInput);
}

}  // namespace
