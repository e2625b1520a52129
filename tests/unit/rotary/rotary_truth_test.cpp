// Recover the truth: R-test files of AC and BC trunnions written by an independent simulator
// (tests/sim/rotary_truth.py: Rodrigues matrices straight from the definitions, 0.5 µm noise,
// location errors away from any grid). Each determined error within 1 µm / 5 µrad of the truth
// and within 3σ; a pose set that cannot determine some errors names them and gives no number.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "ingest/rotary/rotary_parser.h"
#include "tests/unit/rotary/rotary_sim.h"
#include "usecases/rotary/rotary_report.h"

namespace km::rotary {
namespace {

nlohmann::json Analyze(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return usecases::RotaryReportToJson(
      usecases::AnalyzeRotary(ingest::ParseRotaryFile(text.str(), path)));
}

// Every error outside `absent` recovered; those in `absent` reported without a number.
void ExpectRecovered(const nlohmann::json& j, const test::SimulatedFile& f,
                     const std::set<std::string>& absent) {
  for (const auto& [name, truth] : f.truth) {
    const bool angular = name[1] == 'O' && (name[0] == 'A' || name[0] == 'B' || name[0] == 'C');
    const auto& e = j["location_errors"][name + (angular ? "_urad" : "_um")];
    if (absent.count(name)) {
      EXPECT_FALSE(e["identifiable"].get<bool>()) << name;
      EXPECT_TRUE(e["value"].is_null()) << name;
      EXPECT_TRUE(e["sigma"].is_null()) << name;
      continue;
    }
    ASSERT_TRUE(e["identifiable"].get<bool>()) << name;
    const double value = e["value"].get<double>(), sigma = e["sigma"].get<double>();
    std::printf("  %s truth %8.3f got %8.3f  error %7.3f  sigma %6.3f\n", name.c_str(), truth,
                value, value - truth, sigma);
    EXPECT_NEAR(value, truth, angular ? 5.0 : 1.0) << name;
    EXPECT_LE(std::abs(value - truth), 3.0 * sigma) << name;
    EXPECT_GT(sigma, 0.0) << name;
  }
  std::set<std::string> reported;
  for (const auto& n : j["not_identifiable"]) reported.insert(n.get<std::string>());
  EXPECT_EQ(reported, absent);
  EXPECT_NEAR(j["sigma_um"].get<double>(), 0.5, 0.1);
}

TEST(RotaryTruth, AcFullPoseSet) {
  const auto f = test::Simulate("AC", "full", 11);
  const auto j = Analyze(f.path);
  ExpectRecovered(j, f, {});
  EXPECT_EQ(j["rank"], 8);
  EXPECT_TRUE(j["not_separable"].empty());
  EXPECT_EQ(j["poses"], 60);
  EXPECT_LT(j["condition"].get<double>(), 100.0);
}

TEST(RotaryTruth, BcFullPoseSet) {
  const auto f = test::Simulate("BC", "full", 12);
  const auto j = Analyze(f.path);
  ExpectRecovered(j, f, {});
  EXPECT_EQ(j["rank"], 8);
}

TEST(RotaryTruth, RandomPosesOfBothKinematics) {
  for (const char* k : {"AC", "BC"}) {
    const auto f = test::Simulate(k, "random", 13, 200);
    ExpectRecovered(Analyze(f.path), f, {});
  }
}

TEST(RotaryTruth, TiltAtZeroOnlyLeavesTheTiltAxisUndetermined) {
  // C through a turn at A = 0 only: no pose turns the tilt axis, so none of its four errors is
  // determined; the C errors are.
  const auto f = test::Simulate("AC", "tilt0", 14);
  const auto j = Analyze(f.path);
  ExpectRecovered(j, f, {"YOA", "ZOA", "BOA", "COA"});
  EXPECT_EQ(j["rank"], 4);
  ASSERT_EQ(j["not_separable"].size(), 1u);
  EXPECT_EQ(j["not_separable"][0]["sentence"],
            "YOA, ZOA, BOA and COA are not determined by these poses: no pose is moved by them");
  EXPECT_TRUE(j["not_separable"][0]["determined"].is_null());
  const auto g = test::Simulate("BC", "tilt0", 15);
  ExpectRecovered(Analyze(g.path), g, {"XOB", "ZOB", "AOB", "COB"});
}

TEST(RotaryTruth, SphereOnTheCLineCannotSeparatePositionFromDirection) {
  // The sphere on the C line at height h: only the line's offset at the sphere's height is seen,
  // XOC + h·BOC and YOC − h·AOC (µm per µrad = m: h in mm).
  for (const char* k : {"AC", "BC"}) {
    const auto f = test::Simulate(k, "on_axis", 16);
    const auto j = Analyze(f.path);
    ExpectRecovered(j, f, {"XOC", "YOC", "AOC", "BOC"});
    EXPECT_EQ(j["rank"], 6);
    ASSERT_EQ(j["not_separable"].size(), 2u) << j["not_separable"].dump();
    std::set<std::string> determined;
    for (const auto& g : j["not_separable"]) {
      std::printf("  %s: %s\n", k, g["sentence"].get<std::string>().c_str());
      determined.insert(g["determined"].get<std::string>());
    }
    const std::string h = k == std::string("AC") ? "118.2" : "108.9";
    EXPECT_TRUE(determined.count("XOC + " + h + " mm × BOC")) << j["not_separable"].dump();
    EXPECT_TRUE(determined.count("YOC − " + h + " mm × AOC")) << j["not_separable"].dump();
  }
}

}  // namespace
}  // namespace km::rotary
