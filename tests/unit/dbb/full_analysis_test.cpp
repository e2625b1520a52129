// Full DBB analysis of a set: JSON keys of docs/formats.md §3, pairing, minimum zone ≤ least
// squares, servo_lag separated from radius_error by two feeds, absolute mode, plot of a pair.
#include "analysis/dbb/full_analysis.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "analysis/core/errors.h"
#include "report/dbb_json.h"
#include "tests/unit/dbb/dbb_test_util.h"

namespace km::dbb {
namespace {

using effects::EffectId;

const DiagnosisEntry* Find(const DbbTestReport& t, const std::string& name) {
  for (const auto& e : t.diagnosis)
    if (e.effect == name) return &e;
  return nullptr;
}

TEST(FullAnalysis, JsonCarriesContractKeys) {
  SerialDbbSimOptions o;
  o.seed = 4;
  o.lead_deg = 20.0;
  o.fixed_ball_offset_um = {5.0, -4.0};
  o.effects = {{EffectId::kServoMismatch, {0.3}}, {EffectId::kBacklashV, {2.0}}};
  auto tests = testing::SimulatePair(o);
  o.test_id = "T2";
  o.direction = Direction::kCcw;
  tests.push_back(SimulateSerialDbbTest(o));  // unpaired
  const auto rep = AnalyzeDbbSet(tests);
  ASSERT_EQ(rep.tests.size(), 3u);
  ASSERT_EQ(rep.pairs.size(), 1u);
  EXPECT_EQ(rep.pairs[0].ccw, 0u);
  EXPECT_EQ(rep.pairs[0].cw, 1u);
  const auto j = DbbReportToJson(rep);
  ASSERT_EQ(j["tests"].size(), 3u);
  for (const auto& t : j["tests"]) {
    for (const char* k :
         {"test_id", "direction", "mode", "centre_offset_um", "average_radial_error_um",
          "circularity_um", "min_zone_circularity_um", "iso230_4", "harmonics", "diagnosis"}) {
      EXPECT_TRUE(t.contains(k)) << k;
    }
    for (const char* k :
         {"circular_deviation_um", "radial_deviation_max_um", "radial_deviation_min_um"}) {
      EXPECT_TRUE(t["iso230_4"].contains(k)) << k;
    }
    EXPECT_EQ(t["centre_offset_um"].size(), 2u);
    EXPECT_LE(t["min_zone_circularity_um"].get<double>(), t["circularity_um"].get<double>() + 1e-9);
    ASSERT_EQ(t["harmonics"].size(), 10u);
    EXPECT_EQ(t["harmonics"][0]["order"], 1);
    for (const auto& d : t["diagnosis"]) {
      for (const char* k : {"effect", "value", "unit", "contribution_pct"})
        EXPECT_TRUE(d.contains(k));
    }
  }
  EXPECT_EQ(j["tests"][0]["mode"], "centre_corrected");
  EXPECT_EQ(j["tests"][1]["direction"], "cw");
  const auto& pj = j["pairs"][0];
  EXPECT_EQ(pj["test_id"], "T1");
  EXPECT_GT(pj["circular_hysteresis_um"].get<double>(), 0.0);
  EXPECT_GT(pj["bidirectional_circular_deviation_um"].get<double>(), 0.0);
  // The pair is diagnosed jointly: servo mismatch is identified (impossible from one trace).
  const auto* sm = Find(rep.tests[0], "servo_mismatch");
  ASSERT_NE(sm, nullptr);
  EXPECT_NEAR(sm->value[0], 0.3, 0.015);
  EXPECT_EQ(rep.tests[0].diagnosis.front().effect, rep.tests[1].diagnosis.front().effect);
  // Centre offset = circle centre relative to the fixed ball = −(fixed-ball offset).
  const auto* co = Find(rep.tests[0], "centre_offset");
  ASSERT_NE(co, nullptr);
  EXPECT_NEAR(co->value[0], -5.0, 0.05);
  EXPECT_NEAR(co->value[1], 4.0, 0.05);
  // Harmonic order 2 (sin 2θ) of the ccw trace: servo-mismatch ellipse V·Δτ/2 plus the sin 2θ
  // part of the y backlash −(b/2)·sign(cos θ)·sin θ, which is −4b/(3π).
  EXPECT_NEAR(rep.tests[0].harmonics.harmonics[1].sin_um,
              1000.0 / 60.0 * 0.3 / 2.0 - 4.0 * 2.0 / (3.0 * std::numbers::pi), 0.03);
  EXPECT_NEAR(rep.tests[0].harmonics.harmonics[1].cos_um, 0.0, 0.03);
  const auto png = PolarPlotPng(rep, 0);
  EXPECT_GT(png.size(), 1000u);
}

TEST(FullAnalysis, ServoLagSeparatedByTwoFeeds) {
  // c = (1 − K_f²)/K_pp² with K_f = 0, K_pp = 30 /s → c = 1111 ms²; radius error 1.5 µm.
  const double c = 1e6 / (30.0 * 30.0);
  std::vector<DbbTest> tests;
  for (double feed : {500.0, 3000.0}) {
    SerialDbbSimOptions o;
    o.seed = static_cast<unsigned>(feed);
    o.feed_mm_min = feed;
    o.test_id = "F" + std::to_string(static_cast<int>(feed));
    o.effects = {{EffectId::kServoLag, {c}}, {EffectId::kRadiusError, {1.5}}};
    for (auto& t : testing::SimulatePair(o)) tests.push_back(std::move(t));
  }
  const auto rep = AnalyzeDbbSet(tests);
  for (std::size_t i = 0; i < tests.size(); ++i) {
    const double v = tests[i].feed_mm_min / 60.0;
    const double expected = -c * 1e-6 * v * v / (2.0 * 150.0) * 1e3;  // [Fujita thesis] eq. 2.1, µm
    const auto* re = Find(rep.tests[i], "radius_error");
    ASSERT_NE(re, nullptr);
    EXPECT_NEAR(re->value[0], 1.5, 0.075);
    if (std::abs(expected) > 2.0) {
      const auto* sl = Find(rep.tests[i], "servo_lag");
      ASSERT_NE(sl, nullptr) << "test " << i;
      EXPECT_NEAR(sl->value[0], expected, std::max(0.05 * std::abs(expected), 0.1));
    }
  }
}

TEST(FullAnalysis, SinglePairLeavesServoLagInRadiusError) {
  SerialDbbSimOptions o;
  o.effects = {{EffectId::kServoLag, {1000.0}}};
  const auto rep = AnalyzeDbbSet(testing::SimulatePair(o));
  EXPECT_EQ(Find(rep.tests[0], "servo_lag"), nullptr);
  const auto* re = Find(rep.tests[0], "radius_error");
  ASSERT_NE(re, nullptr);
  const double v = 1000.0 / 60.0;
  EXPECT_NEAR(re->value[0], -1000.0 * 1e-6 * v * v / 300.0 * 1e3, 0.01);
}

TEST(FullAnalysis, AbsoluteModeHarmonicsCarryTheCentreError) {
  SerialDbbSimOptions o;
  o.absolute = true;
  o.noise_um = 0.05;
  o.effects = {{EffectId::kCentreOffset, {3.0, 4.0}}};
  const auto rep = AnalyzeDbbSet(testing::SimulatePair(o, false));
  ASSERT_EQ(rep.tests[0].circular.mode, Mode::kAbsolute);
  EXPECT_NEAR(rep.tests[0].harmonics.harmonics[0].amplitude_um, 5.0, 0.01);
  EXPECT_NEAR(rep.tests[0].harmonics.harmonics[0].phase_deg,
              std::atan2(4.0, 3.0) * 180.0 / std::numbers::pi, 0.2);
  EXPECT_EQ(rep.tests[0].iso230_4.radial_reference, "nominal_centre");
}

TEST(FullAnalysis, CoarseSamplingStillAnalysed) {
  SerialDbbSimOptions o;
  o.step_deg = 10.0;  // 36 samples per turn, the coarsest the lead's turn selection accepts
  o.noise_um = 0.05;
  o.effects = {{EffectId::kScaleMismatch, {40.0}}};
  const auto rep = AnalyzeDbbSet(testing::SimulatePair(o, false));
  ASSERT_EQ(rep.tests.size(), 1u);
  EXPECT_LE(rep.tests[0].min_zone_circularity_um, rep.tests[0].circular.circularity_um + 1e-9);
  ASSERT_FALSE(rep.tests[0].diagnosis.empty());
  EXPECT_EQ(rep.tests[0].diagnosis.front().effect, "scale_mismatch");
  EXPECT_NEAR(rep.tests[0].diagnosis.front().value[0], 40.0, 2.0);
}

TEST(FullAnalysis, BadInputNamesTheTest) {
  SerialDbbSimOptions o;
  o.test_id = "broken";
  auto t = SimulateSerialDbbTest(o);
  t.angle_deg.resize(100);
  t.dr_um.resize(100);
  try {
    AnalyzeDbbSet({t});
    FAIL();
  } catch (const km::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("broken"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace km::dbb
