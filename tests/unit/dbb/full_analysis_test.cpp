// Full DBB analysis of a set: JSON keys of docs/formats.md §3, pairing, minimum zone ≤ least
// squares, servo_lag separated from radius_error by two feeds, absolute mode, plot of a pair.
#include "analysis/dbb/full_analysis.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "analysis/core/errors.h"
#include "render/dbb_plot.h"
#include "tests/unit/dbb/dbb_test_util.h"
#include "usecases/dbb_json.h"

namespace km::dbb {
namespace {

using serial_effects::EffectId;

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
  auto tests = test::SimulatePair(o);
  o.test_id = "T2";
  o.direction = Direction::kCcw;
  tests.push_back(SimulateSerialDbbTest(o));  // unpaired
  const auto rep = AnalyzeDbbSet(tests);
  ASSERT_EQ(rep.tests.size(), 3u);
  ASSERT_EQ(rep.pairs.size(), 1u);
  EXPECT_EQ(rep.pairs[0].ccw, 0u);
  EXPECT_EQ(rep.pairs[0].cw, 1u);
  const auto j = usecases::DbbReportToJson(rep);
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
  // H about the common least-squares centre, computed here from the raw samples: at equal
  // angles the centre's correction is the same for both traces (to first order, c²/R ~ 1e-7 µm
  // here), so H = max |dr_ccw(θ) − dr_cw(θ)| over the angles both evaluated turns sample (a flat
  // test: tool-path units = bar units). Both runs sample the same angle grid.
  {
    auto key = [](double deg) { return ((std::llround(deg * 1000.0) % 360000) + 360000) % 360000; };
    auto in_turn = [](const DbbTestReport& r, double deg) {
      const double lo = std::min(r.circular.turn_start_deg, r.circular.turn_end_deg);
      const double hi = std::max(r.circular.turn_start_deg, r.circular.turn_end_deg);
      return deg >= lo - 1e-9 && deg <= hi + 1e-9;
    };
    ASSERT_EQ(rep.tests[0].circular.deviation_factor, 1.0);
    std::map<long long, double> cw;
    for (std::size_t k = 0; k < tests[1].angle_deg.size(); ++k)
      if (in_turn(rep.tests[1], tests[1].angle_deg[k]))
        cw[key(tests[1].angle_deg[k])] = tests[1].dr_um[k];
    double h = 0.0;
    std::size_t matched = 0;
    for (std::size_t k = 0; k < tests[0].angle_deg.size(); ++k) {
      if (!in_turn(rep.tests[0], tests[0].angle_deg[k])) continue;
      const auto it = cw.find(key(tests[0].angle_deg[k]));
      if (it == cw.end()) continue;
      h = std::max(h, std::abs(tests[0].dr_um[k] - it->second));
      ++matched;
    }
    ASSERT_GT(matched, 100u);
    EXPECT_NEAR(pj["circular_hysteresis_um"].get<double>(), h, 0.01);
  }
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
  // The plot of the pair: a PNG of the default 800 px whose two traces are drawn in their
  // colours (ccw BGR 200,60,20; cw 30,30,210) along the reference circle of radius 0.27·800 px:
  // each colour covers at least half its circumference (the other trace and the zone lines
  // overlap it in places).
  const auto png = render::DbbPolarPlotPng(rep, 0);
  const cv::Mat img = cv::imdecode(png, cv::IMREAD_COLOR);
  ASSERT_EQ(img.rows, 800);
  ASSERT_EQ(img.cols, 800);
  auto count = [&](int b, int g, int r) {
    int n = 0;
    for (int y = 0; y < img.rows; ++y)
      for (int x = 0; x < img.cols; ++x) {
        const auto p = img.at<cv::Vec3b>(y, x);
        n += std::abs(p[0] - b) < 30 && std::abs(p[1] - g) < 30 && std::abs(p[2] - r) < 30;
      }
    return n;
  };
  const double half_circumference = std::numbers::pi * 0.27 * 800.0;
  EXPECT_GT(count(200, 60, 20), half_circumference);
  EXPECT_GT(count(30, 30, 210), half_circumference);
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
    for (auto& t : test::SimulatePair(o)) tests.push_back(std::move(t));
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
  const auto rep = AnalyzeDbbSet(test::SimulatePair(o));
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
  const auto rep = AnalyzeDbbSet(test::SimulatePair(o, false));
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
  const auto rep = AnalyzeDbbSet(test::SimulatePair(o, false));
  ASSERT_EQ(rep.tests.size(), 1u);
  EXPECT_LE(rep.tests[0].min_zone_circularity_um, rep.tests[0].circular.circularity_um + 1e-9);
  ASSERT_FALSE(rep.tests[0].diagnosis.empty());
  EXPECT_EQ(rep.tests[0].diagnosis.front().effect, "scale_mismatch");
  EXPECT_NEAR(rep.tests[0].diagnosis.front().value[0], 40.0, 2.0);
}

TEST(FullAnalysis, ParallelAnalysisEqualsAnalysisInOrder) {
  // Two pairs at two feeds (servo lag across units) and an unpaired test: the threaded analysis
  // gives exactly the report of the one-thread run.
  std::vector<DbbTest> tests;
  for (double feed : {500.0, 3000.0}) {
    SerialDbbSimOptions o;
    o.seed = static_cast<unsigned>(feed);
    o.feed_mm_min = feed;
    o.test_id = "F" + std::to_string(static_cast<int>(feed));
    o.effects = {{EffectId::kBacklashU, {2.0}},
                 {EffectId::kReversalSpikeV, {3.0, 1.0}},
                 {EffectId::kCyclicErrorU, {0.6, 0.3, 10.0}}};
    for (auto& t : test::SimulatePair(o)) tests.push_back(std::move(t));
  }
  SerialDbbSimOptions single;
  single.test_id = "S";
  single.effects = {{EffectId::kSquareness, {20.0}}};
  tests.push_back(SimulateSerialDbbTest(single));
  DbbAnalysisOptions in_order, threaded;
  in_order.threads = 1;
  threaded.threads = 4;
  const auto a = usecases::DbbReportToJson(AnalyzeDbbSet(tests, in_order));
  const auto b = usecases::DbbReportToJson(AnalyzeDbbSet(tests, threaded));
  EXPECT_EQ(a.dump(), b.dump());
  EXPECT_EQ(a["pairs"].size(), 2u);
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
