// The law of propagation of uncertainty against the end-gauge calibration of [JCGM 100] annex
// H.1. The truth is the annex's: its stated input values and its results — Table H.1 (the
// budget rows c_i·u(x_i), rounded by the annex to 0.1 nm), u_c(l) = 32 nm, ν_eff(l) ≈ 16 and k
// = 2.12 for p = 95 % (H.1.6), U = k·u_c = 68 nm (the annex multiplies the rounded 2.12 × 32 nm
// = 67.8 nm).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/uncertainty/gum.h"

namespace {

using km::uncertainty::GumInput;
using km::uncertainty::kInfiniteDof;

// Lengths in nm, temperatures in °C, expansion coefficients in 1/°C.
enum EndGaugeIndex { kLs, kD0, kD1, kD2, kAlphaS, kThetaBar, kCyclic, kDeltaAlpha, kDeltaTheta };

// The inputs as the annex states them: the standard's length 50.000 623 mm with u = 25 nm,
// ν = 18; the mean difference 215 nm with u = 5.8 nm, ν = 24, the comparator's random
// effects u = 3.9 nm, ν = 5, and its systematic effects u = 6.7 nm, ν = 8; α_s =
// 11.5 × 10⁻⁶ /°C within ±2 × 10⁻⁶ /°C, rectangular, ν infinite; the bed at −0.1 °C
// with u = 0.2 °C and a cyclic variation of amplitude 0.5 °C, arcsine: u = 0.5/√2 °C;
// δα within ±1 × 10⁻⁶ /°C, rectangular, ν = 50; δθ within ±0.05 °C, rectangular,
// ν = 2.
std::vector<GumInput> EndGaugeInputs() {
  return {
      {"l_s", 50'000'623.0, 25.0, 18.0},
      {"d_mean", 215.0, 5.8, 24.0},
      {"d_random", 0.0, 3.9, 5.0},
      {"d_systematic", 0.0, 6.7, 8.0},
      {"alpha_s", 11.5e-6, 2e-6 / std::sqrt(3.0), kInfiniteDof},
      {"theta_mean", -0.1, 0.2, kInfiniteDof},
      {"theta_cyclic", 0.0, 0.5 / std::sqrt(2.0), kInfiniteDof},
      {"delta_alpha", 0.0, 1e-6 / std::sqrt(3.0), 50.0},
      {"delta_theta", 0.0, 0.05 / std::sqrt(3.0), 2.0},
  };
}

// l = l_s + d − l_s (δα θ + α_s δθ), d = d̄ + d1 + d2, θ = θ̄ + Δ.
double EndGaugeLength(const std::vector<double>& x) {
  const double d = x[kD0] + x[kD1] + x[kD2];
  const double theta = x[kThetaBar] + x[kCyclic];
  return x[kLs] + d - x[kLs] * (x[kDeltaAlpha] * theta + x[kAlphaS] * x[kDeltaTheta]);
}

TEST(GumEndGauge, CombinedUncertaintyDegreesOfFreedomAndCoverageFactor) {
  const auto r = km::uncertainty::PropagateGum(EndGaugeLength, EndGaugeInputs());
  // l = 50.000 838 mm: 50 000 623 + 215 nm.
  EXPECT_NEAR(r.y, 50'000'838.0, 0.5);
  // u_c(l) = 32 nm: the annex rounds √(1 002 nm²) = 31.7 nm.
  EXPECT_NEAR(r.u_c, 32.0, 0.5);
  EXPECT_NEAR(r.u_c * r.u_c, 1002.0, 2.0);
  // ν_eff(l) = 16.7, truncated to 16 (H.1.6, G.6.4). The annex computes it from its rounded
  // rows (Table H.1); from the unrounded inputs 16.75, hence a tolerance of 0.1.
  EXPECT_NEAR(r.nu_eff, 16.7, 0.1);
  EXPECT_EQ(std::floor(r.nu_eff), 16.0);
  // t_95(16) = 2.12 (H.1.6).
  EXPECT_NEAR(r.k, 2.12, 0.005);
  // U = 68 nm (H.1.6); from the unrounded u_c 67.1 nm, within 1 nm of the annex's rounding.
  EXPECT_NEAR(r.U, 68.0, 1.0);
}

TEST(GumEndGauge, BudgetRowsOfTableH1) {
  const auto r = km::uncertainty::PropagateGum(EndGaugeLength, EndGaugeInputs());
  ASSERT_EQ(r.budget.size(), 9u);
  // Table H.1, |c_i|·u(x_i) in nm, to the table's 0.1 nm (tolerance 0.05 nm).
  const double table[] = {25.0, 5.8, 3.9, 6.7, 0.0, 0.0, 0.0, 2.9, 16.6};
  for (std::size_t i = 0; i < r.budget.size(); ++i) {
    EXPECT_NEAR(std::abs(r.budget[i].contribution), table[i], 0.05) << r.budget[i].name;
  }
  // Sensitivity coefficients: c = 1 for l_s and d; c_δθ = −l_s α_s = −575 nm/°C;
  // c_α_s = −l_s δθ = 0 and c_θ = −l_s δα = 0 at the estimates.
  EXPECT_NEAR(r.budget[kLs].sensitivity, 1.0, 1e-6);
  EXPECT_NEAR(r.budget[kD0].sensitivity, 1.0, 1e-6);
  EXPECT_NEAR(r.budget[kDeltaTheta].sensitivity, -575.0, 0.5);
  EXPECT_NEAR(r.budget[kAlphaS].sensitivity, 0.0, 1e-3);
  EXPECT_NEAR(r.budget[kThetaBar].sensitivity, 0.0, 1e-6);
}

TEST(GumEndGauge, ComparatorDifferenceOfH132) {
  // d = d̄ + d1 + d2: u(d) = 9.7 nm and ν_eff(d) = 25.6, with the sensitivity
  // coefficients given. The annex puts its rounded u(d) = 9.7 nm into eq. G.2b; the unrounded
  // 9.68 nm gives 25.45, hence a tolerance of 0.2 on ν_eff.
  const auto all = EndGaugeInputs();
  const std::vector<GumInput> in(all.begin() + kD0, all.begin() + kD2 + 1);
  const auto r = km::uncertainty::PropagateGum(in, {1.0, 1.0, 1.0}, 215.0);
  EXPECT_NEAR(r.u_c, 9.7, 0.05);
  EXPECT_NEAR(r.nu_eff, 25.6, 0.2);
}

TEST(GumQuantiles, TDistributionAgainstTableG2) {
  // Tabulated two-sided t quantiles: to 2 decimals (tolerance 0.005), the normal to 3.
  using km::uncertainty::TwoSidedTQuantile;
  EXPECT_NEAR(TwoSidedTQuantile(0.95, 1), 12.71, 0.005);
  EXPECT_NEAR(TwoSidedTQuantile(0.95, 2), 4.30, 0.005);
  EXPECT_NEAR(TwoSidedTQuantile(0.95, 10), 2.23, 0.005);
  EXPECT_NEAR(TwoSidedTQuantile(0.95, 16), 2.12, 0.005);
  EXPECT_NEAR(TwoSidedTQuantile(0.99, 10), 3.17, 0.005);
  EXPECT_NEAR(TwoSidedTQuantile(0.6827, 10), 1.05, 0.005);
  EXPECT_NEAR(TwoSidedTQuantile(0.95, kInfiniteDof), 1.960, 0.0005);
  EXPECT_NEAR(km::uncertainty::TwoSidedNormalQuantile(0.9973), 3.000, 0.0005);
  // A real ν lies between its neighbours; the coverage factor truncates (G.6.4).
  EXPECT_GT(TwoSidedTQuantile(0.95, 16.7), TwoSidedTQuantile(0.95, 17));
  EXPECT_LT(TwoSidedTQuantile(0.95, 16.7), TwoSidedTQuantile(0.95, 16));
  EXPECT_DOUBLE_EQ(km::uncertainty::CoverageFactor(16.7, 0.95), TwoSidedTQuantile(0.95, 16));
}

TEST(GumCorrelation, FullyCorrelatedInputsAddLinearly) {
  // y = x1 + x2, u1 = 3, u2 = 4: uncorrelated 5; r = +1 gives 7, r = −1 gives 1 ([JCGM 100] §5.2).
  const auto sum = [](const std::vector<double>& x) { return x[0] + x[1]; };
  const std::vector<GumInput> in = {{"x1", 1.0, 3.0}, {"x2", 2.0, 4.0}};
  Eigen::MatrixXd r(2, 2);
  r << 1.0, 1.0, 1.0, 1.0;
  EXPECT_NEAR(km::uncertainty::PropagateGumCorrelated(sum, in, r).u_c, 7.0, 1e-9);
  r << 1.0, -1.0, -1.0, 1.0;
  EXPECT_NEAR(km::uncertainty::PropagateGumCorrelated(sum, in, r).u_c, 1.0, 1e-9);
  EXPECT_NEAR(km::uncertainty::PropagateGum(sum, in).u_c, 5.0, 1e-9);
  // Infinite ν everywhere: the normal coverage factor.
  EXPECT_NEAR(km::uncertainty::PropagateGum(sum, in).k, 1.960, 0.0005);
}

TEST(GumErrors, InvalidArgumentsAreRefused) {
  const auto sum = [](const std::vector<double>& x) { return x[0]; };
  EXPECT_THROW(km::uncertainty::PropagateGum(sum, {{"x", 0.0, -1.0}}), km::InvalidInput);
  EXPECT_THROW(km::uncertainty::PropagateGum(sum, {{"x", 0.0, 1.0}}, 1.0), km::InvalidInput);
  Eigen::MatrixXd bad = Eigen::MatrixXd::Identity(2, 2);
  bad(0, 1) = 0.5;  // not symmetric
  EXPECT_THROW(km::uncertainty::CombinedStandardUncertainty({1, 1}, {1, 1}, bad), km::InvalidInput);
}

}  // namespace
