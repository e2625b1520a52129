// The `uncertainty` object of an R-test result (docs/formats.md §3.17–§3.18, docs/methods.md
// §17.8): u_reading_um propagated by Monte Carlo through the identification. On files of the
// independent simulator (tests/sim/rotary_truth.py) with 0.5 µm noise and u_reading_um 0.5 µm
// stated: the Monte Carlo u of each error within 10 % of the first-order u and within 30 % of σ
// from the residual (the noise is exactly the stated u); the C++ first-order u within 2 % of the
// simulator's own, from a Jacobian by central differences of its forward model; the same file
// gives the same numbers; without u_reading_um the method is "none".
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "analysis/rotary/rotary_uncertainty.h"
#include "ingest/rotary/rotary_parser.h"
#include "tests/unit/rotary/rotary_sim.h"
#include "usecases/rotary/rotary_report.h"

namespace km::rotary {
namespace {

std::string Read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

nlohmann::json AnalyzeText(const std::string& text, const std::string& path) {
  return usecases::RotaryReportToJson(usecases::AnalyzeRotary(ingest::ParseRotaryFile(text, path)));
}

std::string Key(const std::string& name) {
  const bool angular = name[1] == 'O' && (name[0] == 'A' || name[0] == 'B' || name[0] == 'C');
  return name + (angular ? "_urad" : "_um");
}

void ExpectConsistent(const char* kinematics, const std::string& poses, int seed, int count) {
  const auto f = test::Simulate(kinematics, poses, seed, count, "--noise 0.5 --gum-u 0.5");
  const auto t0 = std::chrono::steady_clock::now();
  const auto j = AnalyzeText(Read(f.path), f.path);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("  %s %s: %zu poses, analysis with uncertainty %.0f ms\n", kinematics, poses.c_str(),
              j["poses"].get<std::size_t>(), ms);
  const auto& u = j["uncertainty"];
  ASSERT_EQ(u["method"], "Monte Carlo (JCGM 101)") << u.dump();
  EXPECT_EQ(u["draws"], 500);
  EXPECT_EQ(u["k"], 2.0);
  ASSERT_EQ(u["inputs"].size(), 1u);
  EXPECT_EQ(u["inputs"][0]["input"], "u_reading_um");
  EXPECT_EQ(u["inputs"][0]["u"], 0.5);
  EXPECT_TRUE(u["not_stated"].empty());
  ASSERT_EQ(u["figures"].size(), 8u) << u["figures"].dump();
  const nlohmann::json sim_gum = nlohmann::json::parse(f.output).at("u_gum");
  for (const auto& [name, truth] : f.truth) {
    const std::string key = Key(name);
    ASSERT_TRUE(u["figures"].contains(key)) << key;
    const auto& fig = u["figures"][key];
    const double u_mc = fig["u_um"].get<double>(), u_gum = fig["u_gum_um"].get<double>();
    const double sigma = j["location_errors"][key]["sigma"].get<double>();
    const double value = j["location_errors"][key]["value"].get<double>();
    const double u_py = sim_gum.at(name).get<double>();
    std::printf("  %-9s u_mc %.4f  u_gum %.4f  sigma %.4f  numpy u_gum %.4f  (%s)\n", key.c_str(),
                u_mc, u_gum, sigma, u_py, fig["unit"].get<std::string>().c_str());
    EXPECT_EQ(fig["unit"], key.ends_with("_urad") ? "µrad" : "µm") << key;
    EXPECT_NEAR(u_mc, u_gum, 0.10 * u_gum) << key;
    EXPECT_NEAR(u_mc, sigma, 0.30 * sigma) << key;
    EXPECT_NEAR(u_gum, u_py, 0.02 * u_py) << key;
    EXPECT_DOUBLE_EQ(fig["U_um"].get<double>(), 2.0 * u_mc) << key;
    const double low = fig["interval_um"][0].get<double>(),
                 high = fig["interval_um"][1].get<double>();
    EXPECT_LT(low, value) << key;
    EXPECT_GT(high, value) << key;
    EXPECT_NEAR(high - low, 2.0 * 1.96 * u_mc, 0.2 * 2.0 * 1.96 * u_mc) << key;
    ASSERT_EQ(fig["budget"].size(), 1u);
    EXPECT_EQ(fig["budget"][0]["input"], "u_reading_um");
    EXPECT_DOUBLE_EQ(fig["budget"][0]["contribution_um"].get<double>(), u_mc);
  }
  EXPECT_TRUE(u["warnings"].empty()) << u["warnings"].dump();
}

TEST(RotaryUncertainty, MonteCarloAgreesWithFirstOrderAndResidualSigmaAc) {
  ExpectConsistent("AC", "full", 21, 1000);
}

TEST(RotaryUncertainty, MonteCarloAgreesWithFirstOrderAndResidualSigmaBc) {
  ExpectConsistent("BC", "random", 22, 300);
}

TEST(RotaryUncertainty, SameFileSameNumbers) {
  const auto f = test::Simulate("AC", "full", 23);
  const std::string text = Read(f.path);
  const auto a = AnalyzeText(text, f.path), b = AnalyzeText(text, f.path);
  EXPECT_EQ(a["uncertainty"].dump(), b["uncertainty"].dump());
  EXPECT_EQ(a["uncertainty"]["seed"], 1710);
}

TEST(RotaryUncertainty, WithoutReadingUncertaintyNothingIsPropagated) {
  const auto f = test::Simulate("AC", "full", 24);
  std::string text = Read(f.path);
  const auto at = text.find("# u_reading_um:");
  ASSERT_NE(at, std::string::npos);
  text.erase(at, text.find('\n', at) + 1 - at);
  const auto j = AnalyzeText(text, f.path);
  const auto& u = j["uncertainty"];
  EXPECT_EQ(u["method"], "none: no input uncertainty stated");
  EXPECT_TRUE(u["figures"].empty());
  EXPECT_EQ(u["not_stated"], nlohmann::json::array({"u_reading_um"}));
  EXPECT_TRUE(j["u_reading_um"].is_null());
  EXPECT_FALSE(j["location_errors"]["YOA_um"]["sigma"].is_null());  // σ from the residual stays
}

TEST(RotaryUncertainty, UndeterminedErrorsGetNoEntry) {
  const auto f = test::Simulate("AC", "tilt0", 25);
  const auto j = AnalyzeText(Read(f.path), f.path);
  const auto& u = j["uncertainty"];
  ASSERT_EQ(u["method"], "Monte Carlo (JCGM 101)");
  EXPECT_EQ(u["figures"].size(), 4u);
  for (const char* key : {"YOA_um", "ZOA_um", "BOA_urad", "COA_urad"}) {
    EXPECT_FALSE(u["figures"].contains(key)) << key;
  }
  for (const char* key : {"XOC_um", "YOC_um", "AOC_urad", "BOC_urad"}) {
    EXPECT_TRUE(u["figures"].contains(key)) << key;
  }
  ASSERT_FALSE(u["notes"].empty());
  EXPECT_EQ(u["notes"].back(),
            "YOA, ZOA, BOA and COA are not determined by these poses: no uncertainty is given for "
            "them");
}

// The draws of a file: 500 up to 2 000 poses, then 200, fewer where M × poses would pass 10⁶,
// never below 50 — so the largest file an upload accepts costs about as much as 1 400 poses.
TEST(RotaryUncertainty, DrawsFallWithThePosesWithinABudget) {
  EXPECT_EQ(ReadingDraws(60), 500u);
  EXPECT_EQ(ReadingDraws(2000), 500u);
  EXPECT_EQ(ReadingDraws(2001), 200u);
  EXPECT_EQ(ReadingDraws(5000), 200u);
  EXPECT_EQ(ReadingDraws(10000), 100u);
  EXPECT_EQ(ReadingDraws(20000), 50u);
  EXPECT_EQ(ReadingDraws(100000), 50u);
  EXPECT_LE(ReadingDraws(20000) * 20000, 1'000'000u);
}

}  // namespace
}  // namespace km::rotary
