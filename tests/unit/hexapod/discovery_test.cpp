// Hexapod model-gap discovery (analysis/discovery/): on simulated absolute test sets (15 tests ×
// CW/CCW, noise 0.3 µm) starting from kinematics only, the hidden effect is named, the gap
// shrinks to the noise, the fitted values match the truth; a null control adds nothing.
#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "analysis/discovery/hexapod_family.h"
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
  o.result = RunDiscovery(family);
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
    EXPECT_EQ(o.result.verdict, "complete");
    EXPECT_LT(o.result.unexplained_rms_um, 1.3 * 0.3);
  }
}

TEST(HexapodDiscovery, GravityThenFrictionLargerFirst) {
  const auto o = Discover(Simulate(
      {{"gravity_deflection", {{0, 1.52e-5}}}, {"joint_friction", {{0, 8.88}, {1, 2.0}}}}));
  ASSERT_EQ(o.result.steps.size(), 2u);
  EXPECT_EQ(o.result.steps[0].added_effect, "gravity_deflection");
  EXPECT_EQ(o.result.steps[1].added_effect, "joint_friction");
  // Each step removes its effect's share: gravity (even) leaves the friction (odd) part, about
  // what a friction-only machine shows; friction then leaves the noise.
  const auto friction_only = Discover(Simulate({{"joint_friction", {{0, 8.88}, {1, 2.0}}}}));
  const double friction_gap = friction_only.result.steps.at(0).gap_rms_before_um;
  EXPECT_LT(o.result.steps[0].gap_rms_after_um, 1.2 * friction_gap);
  // The shrink of the gap above the injected noise (0.3 µm) is at least 80 %.
  auto excess = [](double rms) { return std::sqrt(std::max(0.0, rms * rms - 0.09)); };
  EXPECT_LT(excess(o.result.steps[1].gap_rms_after_um),
            0.2 * excess(o.result.steps[1].gap_rms_before_um));
  EXPECT_LT(o.result.unexplained_rms_um, 0.2 * o.result.steps[0].gap_rms_before_um);
  EXPECT_LT(o.result.unexplained_rms_um, 1.3 * 0.3);
  EXPECT_NEAR(Param(o.history.back(), "gravity_deflection", 0), 1.52e-5, 0.05 * 1.52e-5);
  EXPECT_EQ(o.result.verdict, "complete");
  EXPECT_FALSE(o.result.steps[1].evidence.sentence.empty());
}

TEST(HexapodDiscovery, ToolLengthErrorOfOneToolAndDrift) {
  const auto o = Discover(
      Simulate({{"tool_length_error", {{0, -62.0}, {1, 0.0}}}, {"thermal_drift", {{0, 20.0}}}}));
  ASSERT_EQ(o.result.steps.size(), 2u);
  std::set<std::string> named;
  for (const auto& st : o.result.steps) named.insert(st.added_effect);
  EXPECT_TRUE(named.count("tool_length_error"));
  EXPECT_TRUE(named.count("thermal_drift"));
  EXPECT_NEAR(Param(o.history.back(), "tool_length_error", 0), -62.0, 0.05 * 62.0);
  EXPECT_NEAR(Param(o.history.back(), "tool_length_error", 1), 0.0, 2.0);
  EXPECT_NEAR(Param(o.history.back(), "thermal_drift", 0), 20.0, 0.05 * 20.0);
  EXPECT_LT(o.result.unexplained_rms_um, 1.3 * 0.3);
}

}  // namespace
}  // namespace km::discovery
