// Laser positioning: recover the truth of simulated runs (linear and pendulum cycles, a
// decreasing axis, raw readings needing the refractive index, a 23 °C machine, a 3-run file)
// and compare every figure with an independent evaluation (tests/sim/positioning_truth.py)
// within 0.002 µm; the refractive index against published values; the compensation tables.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "analysis/core/errors.h"
#include "analysis/positioning/air.h"
#include "ingest/positioning_parser.h"
#include "tests/unit/expect_error.h"
#include "tests/unit/positioning/positioning_sim.h"
#include "usecases/positioning_report.h"

namespace km::positioning {
namespace {

using nlohmann::json;
using test::Truth;

constexpr double kTolUm = 0.002;

std::vector<double> Targets(double from, double to, int count) {
  std::vector<double> t;
  for (int i = 0; i < count; ++i) t.push_back(from + (to - from) * i / (count - 1));
  return t;
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "km_positioning_test";
  std::filesystem::create_directories(dir);
  const auto path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

json Independent(const std::string& path) {
  const std::string cmd = "/usr/bin/python3 tests/sim/positioning_truth.py '" + path + "'";
  FILE* p = popen(cmd.c_str(), "r");
  EXPECT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  while (p && fgets(buf, sizeof buf, p)) out += buf;
  EXPECT_EQ(p ? pclose(p) : -1, 0) << out;
  return json::parse(out);
}

json Product(const std::string& name, const std::string& text) {
  return usecases::PositioningReportToJson(
      usecases::AnalyzePositioning(ingest::ParsePositioningFile(text, name)));
}

void ExpectSameFigures(const json& got, const json& want) {
  for (const char* key :
       {"reversal_value_um", "mean_reversal_value_um", "repeatability_up_um",
        "repeatability_down_um", "repeatability_um", "systematic_deviation_up_um",
        "systematic_deviation_down_um", "systematic_deviation_um", "mean_deviation_range_um",
        "accuracy_up_um", "accuracy_down_um", "accuracy_um"}) {
    EXPECT_NEAR(got[key].get<double>(), want[key].get<double>(), kTolUm) << key;
  }
  EXPECT_EQ(got["iso230_2_compliant"], want["iso230_2_compliant"]);
  for (const char* key : {"target_mm", "mean_up_um", "mean_down_um", "s_up_um", "s_down_um",
                          "reversal_um", "mean_bidirectional_um"}) {
    ASSERT_EQ(got["targets"][key].size(), want["targets"][key].size()) << key;
    for (std::size_t i = 0; i < got["targets"][key].size(); ++i) {
      EXPECT_NEAR(got["targets"][key][i].get<double>(), want["targets"][key][i].get<double>(),
                  kTolUm)
          << key << "[" << i << "]";
    }
  }
  for (const char* key : {"P_um", "Ps_um", "U_um", "Pa_um"}) {
    EXPECT_NEAR(got["vdi3441"][key].get<double>(), want["vdi3441"][key].get<double>(), kTolUm)
        << key;
  }
  EXPECT_NEAR(got["air"]["refractive_index"].get<double>(), want["refractive_index"].get<double>(),
              1e-12);
}

// The corrected mean deviations recover the truth within the noise of the means.
void ExpectTruthRecovered(const json& got, const Truth& t) {
  const double tol = 5.0 * t.noise_um / std::sqrt(double(t.runs)) + 1e-3;
  const auto& tg = got["targets"];
  for (std::size_t i = 0; i < tg["target_mm"].size(); ++i) {
    const double p = tg["target_mm"][i].get<double>();
    EXPECT_NEAR(tg["mean_up_um"][i].get<double>(), test::TrueDeviationUm(t, p, 1), tol) << p;
    EXPECT_NEAR(tg["mean_down_um"][i].get<double>(), test::TrueDeviationUm(t, p, -1), tol) << p;
    EXPECT_NEAR(tg["reversal_um"][i].get<double>(), t.reversal_um, 2.0 * tol) << p;
  }
}

json CheckCase(const std::string& name, const Truth& t) {
  const std::string text = test::SimulateFile(t);
  const json got = Product(name, text);
  ExpectSameFigures(got, Independent(WriteTemp(name, text)));
  ExpectTruthRecovered(got, t);
  return got;
}

TEST(PositioningTruth, LinearCycle) {
  Truth t;
  t.targets_mm = Targets(0.0, 1000.0, 11);
  const json j = CheckCase("linear.txt", t);
  EXPECT_TRUE(j["iso230_2_compliant"].get<bool>());
  EXPECT_TRUE(j["warnings"].empty());
  EXPECT_EQ(j["runs"], 5);
}

TEST(PositioningTruth, PendulumCycleMeasuredColumn) {
  Truth t;
  t.cycle = "pendulum";
  t.deviation_column = false;
  t.runs = 6;
  t.seed = 11;
  t.targets_mm = Targets(12.5, 812.5, 9);
  CheckCase("pendulum.txt", t);
}

TEST(PositioningTruth, DecreasingAxis) {
  Truth t;
  t.targets_mm = Targets(0.0, -600.0, 13);  // the axis travels towards smaller coordinates first
  t.reversal_um = -3.0;
  t.seed = 3;
  const json j = CheckCase("decreasing.txt", t);
  EXPECT_DOUBLE_EQ(j["targets"]["target_mm"][0].get<double>(), -600.0);  // reported ascending
}

TEST(PositioningTruth, RawReadingsAndWarmMachine) {
  Truth t;
  t.targets_mm = Targets(0.0, 1500.0, 16);
  t.datum_mm = 0.0;
  t.raw = true;
  t.warm = true;
  t.deviation_column = false;
  // The n the laser should have used, written out from the published equation by the truth
  // script (it shares no code with the product).
  t.refractive_index = Independent(WriteTemp("air_probe.txt", test::SimulateFile([&] {
                                               Truth probe = t;
                                               probe.runs = 2;
                                               probe.targets_mm = Targets(0, 100, 2);
                                               return probe;
                                             }())))["refractive_index"]
                           .get<double>();
  const json j = CheckCase("raw_warm.txt", t);
  EXPECT_TRUE(j["air"]["applied"].get<bool>());
  EXPECT_TRUE(j["material"]["applied"].get<bool>());
  // Sizes at the end of the axis: −(n − 1)·1500 mm and −11.5 ppm/K · 3 K · 1500 mm.
  EXPECT_NEAR(j["air"]["correction_at_end_um"].get<double>(),
              1500.0 * 1000.0 * (1.0 / t.refractive_index - 1.0), 1e-6);
  EXPECT_NEAR(j["material"]["correction_at_end_um"].get<double>(), -51.75, 1e-9);
}

TEST(PositioningTruth, ThreeRunsAreNotCompliant) {
  Truth t;
  t.runs = 3;
  t.targets_mm = Targets(0.0, 500.0, 6);
  const std::string text = test::SimulateFile(t);
  const json got = Product("three.txt", text);
  ExpectSameFigures(got, Independent(WriteTemp("three.txt", text)));
  EXPECT_FALSE(got["iso230_2_compliant"].get<bool>());
  ASSERT_EQ(got["warnings"].size(), 1u);
  EXPECT_TRUE(km::test::Contains(got["warnings"][0].get<std::string>(), "3 runs"));
}

// Published values of the NIST calculator's Edlén form, 633 nm, 101 325 Pa (README examples of
// phn/ref_index, an implementation of [NIST refractive index]).
TEST(RefractiveIndex, PublishedValues) {
  EXPECT_NEAR(RefractiveIndexOfAir({20.0, 101325.0, 20.0, 633.0}), 1.0002716291691649, 1e-8);
  EXPECT_NEAR(RefractiveIndexOfAir({20.0, 101325.0, 80.0, 633.0}), 1.0002711197635226, 1e-8);
  EXPECT_NEAR(RefractiveIndexOfAir({60.0, 101325.0, 80.0, 633.0}), 1.0002339748542823, 1e-8);
  // Humidity lowers n, temperature lowers n, pressure raises it.
  EXPECT_LT(RefractiveIndexOfAir({20.0, 101325.0, 80.0, 633.0}),
            RefractiveIndexOfAir({20.0, 101325.0, 20.0, 633.0}));
}

TEST(RefractiveIndex, RefusesOutOfRange) {
  EXPECT_EQ(km::test::Expect<InvalidInput>([] {
              RefractiveIndexOfAir({20.0, 101325.0, 140.0, 633.0});
            }).field(),
            "air_humidity_pct");
  EXPECT_EQ(km::test::Expect<InvalidInput>([] {
              RefractiveIndexOfAir({101.0, 101325.0, 80.0, 633.0});
            }).field(),
            "air_temperature_c");
  EXPECT_EQ(km::test::Expect<InvalidInput>([] {
              RefractiveIndexOfAir({20.0, 5000.0, 50.0, 633.0});
            }).field(),
            "air_pressure_pa");
}

}  // namespace
}  // namespace km::positioning
