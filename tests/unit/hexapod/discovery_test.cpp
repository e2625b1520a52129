// Hexapod model-gap discovery (analysis/discovery/): on simulated absolute test sets (15 tests ×
// CW/CCW, noise 0.3 µm) starting from kinematics only, the hidden effect is named, the gap
// shrinks to the noise, the fitted values match the truth; a null control adds nothing.
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/discovery/hexapod_family.h"
#include "analysis/hexapod/compensation.h"
#include "tests/unit/hexapod/effects_fixture.h"

namespace km::discovery {
namespace {

using hexapod::test::Scenario;
using hexapod::test::Simulate;

struct Outcome {
  EngineResult result;
  std::vector<hexapod::EffectFitResult> history;
};

Outcome Discover(const Scenario& s) {
  const auto data = hexapod::PrepareEffectFit(s.nominal, &s.phys, s.tests, s.starts,
                                              hexapod::CalibrationMethod::kAbsolute, 0);
  HexapodFamily family(data, {});
  Outcome o;
  o.result = RunDiscovery(family, HexapodEngineOptions());
  o.history = family.History();
  return o;
}

double Param(const hexapod::EffectFitResult& f, const std::string& effect, int i) {
  for (const auto& a : f.effects)
    if (effect == a.effect->Name()) return a.params[static_cast<std::size_t>(i)].value;
  return std::nan("");
}

TEST(HexapodDiscovery, NullControlAddsNothing) {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    const auto o = Discover(Simulate({}, true, 180, seed));
    EXPECT_TRUE(o.result.steps.empty())
        << "seed " << seed << ": added " << o.result.steps.front().added_effect;
    EXPECT_EQ(o.result.verdict, discovery::Verdict::kComplete);
    EXPECT_LT(o.result.unexplained_rms_um, 1.3 * 0.3);
  }
}

// AR(1) noise (ρ per sample) plus a slow wander over each test, σ about `sigma_um` in all.
void AddColouredNoise(Scenario& s, double rho, double sigma_um, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (auto& t : s.tests) {
    double x = unit(rng) * sigma_um * 0.8;
    const double phase = 6.283 * unit(rng), wander = 0.45 * sigma_um * unit(rng);
    for (std::size_t i = 0; i < t.dr_um.size(); ++i) {
      x = rho * x + std::sqrt(1.0 - rho * rho) * 0.8 * sigma_um * unit(rng);
      t.dr_um[i] += x + wander * std::sin(phase + 3.0 * static_cast<double>(i) / t.dr_um.size());
    }
  }
}

TEST(HexapodDiscovery, ColouredNoiseOnAPerfectMachineIsNoMisfit) {
  for (std::uint32_t seed : {4u}) {
    auto s = Simulate({}, true, 720, seed);  // white noise 0.3 µm
    AddColouredNoise(s, 0.97, 0.9, seed);
    const auto o = Discover(s);
    EXPECT_TRUE(o.result.steps.empty())
        << "seed " << seed << ": added " << o.result.steps.front().added_effect;
    EXPECT_EQ(o.result.verdict, discovery::Verdict::kComplete) << "seed " << seed;
    // The white floor from successive differences misses coloured noise; the repeatability
    // floor of the CW/CCW pairs sees it.
    EXPECT_LT(o.result.noise_floor_um, 0.5 * o.result.repeatability_floor_um);
    EXPECT_GT(o.result.repeatability_floor_um, 0.6);
  }
}

TEST(HexapodDiscovery, AnUnmodelledKinematicErrorIsAMisfitAndDescribed) {
  const auto o = Discover(Simulate({}, true, 180, 6, 0.15));
  EXPECT_TRUE(o.result.steps.empty())
      << "added " << o.result.steps.front().added_effect << ": " << o.result.steps.front().variant;
  EXPECT_EQ(o.result.verdict, discovery::Verdict::kModelMisfit);
  const auto& m = o.result.misfit;
  EXPECT_NE(m.sentence.find("No registered effect explains"), std::string::npos) << m.sentence;
  EXPECT_GT(m.figures.at("even_part_pct"), 80.0) << m.sentence;  // geometric: alike CW/CCW
  EXPECT_TRUE(m.figures.count("strongest_harmonic_order"));
  EXPECT_TRUE(m.figures.count("worst_test_1_rms_um"));
}

TEST(HexapodDiscovery, GravityThenFrictionLargerFirst) {
  // Truths away from the machine file (1.52e-5, 8.88 N·m, 0.0139 m) and off the ramp grid.
  const auto o = Discover(Simulate({{"gravity_deflection", {{0, 1.37e-5}}},
                                    {"joint_friction", {{0, 10.2}, {1, 1.37}, {2, 0.0121}}}}));
  ASSERT_EQ(o.result.steps.size(), 2u);
  EXPECT_EQ(o.result.steps[0].added_effect, "gravity_deflection");
  EXPECT_EQ(o.result.steps[1].added_effect, "joint_friction");
  // Each step removes its effect's share: gravity (even) leaves the friction (odd) part, about
  // what a friction-only machine shows; friction then leaves the noise.
  const auto friction_only =
      Discover(Simulate({{"joint_friction", {{0, 10.2}, {1, 1.37}, {2, 0.0121}}}}));
  const double friction_gap = friction_only.result.steps.at(0).gap_rms_before_um;
  EXPECT_LT(o.result.steps[0].gap_rms_after_um, 1.2 * friction_gap);
  // The shrink of the gap above the injected noise (0.3 µm) is at least 80 %.
  auto excess = [](double rms) { return std::sqrt(std::max(0.0, rms * rms - 0.09)); };
  EXPECT_LT(excess(o.result.steps[1].gap_rms_after_um),
            0.2 * excess(o.result.steps[1].gap_rms_before_um));
  EXPECT_LT(o.result.unexplained_rms_um, 0.2 * o.result.steps[0].gap_rms_before_um);
  EXPECT_LT(o.result.unexplained_rms_um, 1.3 * 0.3);
  EXPECT_NEAR(Param(o.history.back(), "gravity_deflection", 0), 1.37e-5, 0.03 * 1.37e-5);
  EXPECT_NEAR(Param(o.history.back(), "joint_friction", 0), 10.2, 0.15 * 10.2);
  EXPECT_EQ(o.result.verdict, discovery::Verdict::kComplete);
  EXPECT_FALSE(o.result.steps[1].evidence.sentence.empty());
}

// [PM-600 report] table 4.5: correcting the command by the found gravity deflection leaves the
// predicted traces rounder than without; the preview lists gravity only and every test.
TEST(HexapodDiscovery, CompensatingTheFoundGravityRoundsThePredictedTraces) {
  const auto s = Simulate({{"gravity_deflection", {{0, 1.37e-5}}}});
  const auto data = hexapod::PrepareEffectFit(s.nominal, &s.phys, s.tests, s.starts,
                                              hexapod::CalibrationMethod::kAbsolute, 0);
  HexapodFamily family(data, {});
  const auto result = RunDiscovery(family, HexapodEngineOptions());
  ASSERT_EQ(result.steps.size(), 1u);
  const auto preview = hexapod::PreviewCompensation(data, family.History().back());
  ASSERT_TRUE(preview.has_value());
  EXPECT_EQ(preview->compensated_effects, std::vector<std::string>{"gravity_deflection"});
  ASSERT_EQ(preview->tests.size(), s.tests.size());
  double without = 0.0, with = 0.0;
  for (const auto& t : preview->tests) {
    without += t.circularity_without_compensation_um;
    with += t.predicted_circularity_with_compensation_um;
  }
  EXPECT_LT(with, 0.7 * without) << "with " << with << " µm, without " << without << " µm";
  // A machine without gravity or friction in its model has no preview.
  EXPECT_FALSE(hexapod::PreviewCompensation(data, hexapod::EffectFitResult{}).has_value());
}

TEST(HexapodDiscovery, ToolLengthErrorOfOneToolAndDrift) {
  const auto o = Discover(
      Simulate({{"tool_length_error", {{0, -47.3}, {1, 0.0}}}, {"thermal_drift", {{0, 8.37}}}}));
  ASSERT_EQ(o.result.steps.size(), 2u);
  std::set<std::string> named;
  for (const auto& st : o.result.steps) named.insert(st.added_effect);
  EXPECT_TRUE(named.count("tool_length_error"));
  EXPECT_TRUE(named.count("thermal_drift"));
  EXPECT_NEAR(Param(o.history.back(), "tool_length_error", 0), -47.3, 1.0);
  EXPECT_NEAR(Param(o.history.back(), "tool_length_error", 1), 0.0, 1.0);
  EXPECT_NEAR(Param(o.history.back(), "thermal_drift", 0), 8.37, 0.03 * 8.37);
  EXPECT_LT(o.result.unexplained_rms_um, 1.3 * 0.3);
}

}  // namespace
}  // namespace km::discovery
