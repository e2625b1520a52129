// The missing-effect workflow on R-test files written by the independent simulator
// (tests/sim/rotary_truth.py --hidden …, 0.5 µm noise): a hidden angular positioning error of C
// and a hidden drift of the C line are named with values within 3σ of the truth and the gap falls
// to the noise; a machine with location errors alone has nothing named over many seeds; an error
// no candidate models ends in a described misfit.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "ingest/rotary/rotary_parser.h"
#include "tests/unit/rotary/rotary_sim.h"
#include "usecases/rotary/rotary_discover_report.h"

namespace km::rotary {
namespace {

nlohmann::json Discover(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const auto r = usecases::DiscoverRotary(ingest::ParseRotaryFile(text.str(), path));
  for (const auto& s : usecases::RotaryDiscoverySteps(r)) std::printf("  %s\n", s.c_str());
  return usecases::RotaryDiscoveryToJson(r);
}

std::vector<std::string> Named(const nlohmann::json& j) {
  std::vector<std::string> out;
  for (const auto& n : j["named"]) out.push_back(n["effect"].get<std::string>());
  return out;
}

// Parameter `key` of named effect `effect` within 3σ of `truth` (0 where the simulator has none).
void ExpectWithin3Sigma(const nlohmann::json& j, const std::string& effect, const std::string& key,
                        double truth) {
  for (const auto& n : j["named"]) {
    if (n["effect"] != effect) continue;
    const auto& p = n["parameters"][key];
    ASSERT_TRUE(p["determined"].get<bool>()) << key;
    const double v = p["value"].get<double>(), s = p["sigma"].get<double>();
    std::printf("  %-28s truth %8.3f got %8.3f  sigma %6.3f\n", key.c_str(), truth, v, s);
    EXPECT_LE(std::abs(v - truth), 3.0 * s) << key;
    EXPECT_GT(s, 0.0) << key;
    return;
  }
  ADD_FAILURE() << effect << " not named";
}

void ExpectGapShrinksToNoise(const nlohmann::json& j) {
  const auto& steps = j["steps"];
  for (std::size_t i = 1; i + 1 < steps.size(); ++i) {
    EXPECT_LT(steps[i]["rms_after_um"].get<double>(), steps[i]["rms_before_um"].get<double>());
  }
  EXPECT_NEAR(j["sigma_um"].get<double>(), 0.5, 0.06);
  EXPECT_EQ(j["verdict"], "complete");
  EXPECT_TRUE(j["misfit"].is_null());
}

void ExpectCAngle(const nlohmann::json& j, const nlohmann::json& h) {
  const std::string e = "c_angular_positioning";
  ExpectWithin3Sigma(j, e, "C_angle_cos1_urad", h["cos1_urad"].get<double>());
  ExpectWithin3Sigma(j, e, "C_angle_sin1_urad", 0.0);
  ExpectWithin3Sigma(j, e, "C_angle_cos2_urad", 0.0);
  ExpectWithin3Sigma(j, e, "C_angle_sin2_urad", h["sin2_urad"].get<double>());
  ExpectWithin3Sigma(j, e, "C_angle_scale_urad_per_rad", h["scale_urad_per_rad"].get<double>());
}

void ExpectDrift(const nlohmann::json& j, const nlohmann::json& h, char tilt) {
  const std::string e = "thermal_drift";
  ExpectWithin3Sigma(j, e, "drift_XOC_um_per_h", h["XOC_um_per_h"].get<double>());
  ExpectWithin3Sigma(j, e, "drift_YOC_um_per_h", h["YOC_um_per_h"].get<double>());
  const std::string t(1, tilt);
  ExpectWithin3Sigma(j, e, "drift_" + std::string(tilt == 'A' ? "Y" : "X") + "O" + t + "_um_per_h",
                     0.0);
  ExpectWithin3Sigma(j, e, "drift_ZO" + t + "_um_per_h", 0.0);
}

void ExpectLocationErrors(const nlohmann::json& j, const test::SimulatedFile& f) {
  for (const auto& [name, truth] : f.truth) {
    const bool angular = name[1] == 'O' && (name[0] == 'A' || name[0] == 'B' || name[0] == 'C');
    const auto& e = j["location_errors"][name + (angular ? "_urad" : "_um")];
    ASSERT_TRUE(e["determined"].get<bool>()) << name;
    EXPECT_LE(std::abs(e["value"].get<double>() - truth), 3.0 * e["sigma"].get<double>()) << name;
  }
}

TEST(RotaryDiscover, HiddenCAngleIsNamed) {
  const auto f = test::Simulate("AC", "full", 21, 1000, "--hidden c_angle --dt 60");
  const auto j = Discover(f.path);
  EXPECT_EQ(Named(j), std::vector<std::string>{"c_angular_positioning"});
  ExpectCAngle(j, f.hidden["c_angle"]);
  ExpectGapShrinksToNoise(j);
  ExpectLocationErrors(j, f);
}

TEST(RotaryDiscover, HiddenDriftOfTheCLineIsNamed) {
  const auto f = test::Simulate("BC", "full", 22, 1000, "--hidden drift --dt 60");
  const auto j = Discover(f.path);
  EXPECT_EQ(Named(j), std::vector<std::string>{"thermal_drift"});
  ExpectDrift(j, f.hidden["drift"], 'B');
  ExpectGapShrinksToNoise(j);
  ExpectLocationErrors(j, f);
}

TEST(RotaryDiscover, BothHiddenEffectsAreNamedOnBothKinematics) {
  for (const char* k : {"AC", "BC"}) {
    const auto f = test::Simulate(k, "full", 23, 1000, "--hidden c_angle,drift --dt 60");
    const auto j = Discover(f.path);
    const auto named = Named(j);
    ASSERT_EQ(named.size(), 2u) << j["step_sentences"].dump();
    EXPECT_EQ(std::set<std::string>(named.begin(), named.end()),
              (std::set<std::string>{"c_angular_positioning", "thermal_drift"}));
    ExpectCAngle(j, f.hidden["c_angle"]);
    ExpectDrift(j, f.hidden["drift"], k[0]);
    ExpectGapShrinksToNoise(j);
    ExpectLocationErrors(j, f);
    EXPECT_GT(j["steps"][0]["rms_after_um"].get<double>(), 2.0);  // the gap the effects leave
  }
}

TEST(RotaryDiscover, NothingNamedOnLocationErrorsAloneOverManySeeds) {
  int false_alarms = 0;
  for (int seed = 100; seed < 110; ++seed) {
    for (const char* k : {"AC", "BC"}) {
      const auto f = test::Simulate(k, "full", seed, 1000, "--dt 60");
      const auto j = Discover(f.path);
      false_alarms += int(j["named"].size());
      EXPECT_EQ(j["verdict"], "complete");
    }
  }
  EXPECT_EQ(false_alarms, 0);
}

TEST(RotaryDiscover, AnErrorNoCandidateModelsEndsInADescribedMisfit) {
  // A radial error motion of the tilt axis, 3 µm × sin 3t along Z: not a candidate.
  const auto f = test::Simulate("AC", "full", 24, 1000, "--hidden tilt_radial");
  const auto j = Discover(f.path);
  EXPECT_EQ(j["verdict"], "model misfit");
  ASSERT_TRUE(j["misfit"].is_string());
  std::printf("  %s\n", j["misfit"].get<std::string>().c_str());
  EXPECT_NE(j["misfit"].get<std::string>().find("no candidate explains it"), std::string::npos);
}

}  // namespace
}  // namespace km::rotary
