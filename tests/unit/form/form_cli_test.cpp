// `kinemetric form straightness|flatness|parallelism` run through the command registry (the
// command file is compiled into this test): docs/formats.md §3 keys, reversal pairing, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "tests/unit/cli_test_fixture.h"

namespace km::cli {
namespace {

class FormCli : public test::CliTest {
 protected:
  static nlohmann::json Run(const std::string& command, std::vector<std::string> files) {
    std::ostringstream out;
    EXPECT_EQ(Registry().at(command).run(JsonArgs(std::move(files)), out), 0);
    return nlohmann::json::parse(out.str());
  }
};

// A straightness file reading machine_sign * machine + artefact_sign * artefact + noise, the
// machine error a 55 mm waviness, the artefact error a bow: signs (+1, +1) for set-up a, (+1, -1)
// for b with the artefact turned over, (-1, +1) for b with the sensor moved across as well.
std::string StraightnessText(const std::string& extra_header, double artefact_sign, unsigned seed,
                             double machine_sign = 1.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::ostringstream s;
  s << "# format: kinemetric-straightness/1\n# machine_id: m1\n# axis: X\n"
       "# error_direction: Z\n# sensor: capacitance\n# reference: optical_flat\n"
    << extra_header << "position_mm,deviation_um\n";
  for (int i = 0; i <= 300; ++i) {
    const double x = i;
    const double machine = 0.2 * std::cos(2.0 * std::numbers::pi * x / 55.0);
    const double artefact = 1e-5 * (x - 150.0) * (x - 150.0);
    s << x << "," << machine_sign * machine + artefact_sign * artefact + noise(rng) << "\n";
  }
  return s.str();
}

TEST_F(FormCli, StraightnessOneFileHasTheContractKeysAtTopLevel) {
  const std::string f = Write("a.txt", StraightnessText("", 1.0, 1));
  const nlohmann::json j = Run("form straightness", {f});
  for (const char* k : {"straightness_lsq_um", "straightness_min_zone_um",
                        "straightness_end_point_um", "slope_um_per_m", "periodic", "reference"}) {
    EXPECT_TRUE(j.contains(k)) << k;
  }
  EXPECT_FALSE(j.contains("profiles"));
  EXPECT_EQ(j["reference"], "least_squares_line");
  ASSERT_GE(j["periodic"].size(), 1u);
  EXPECT_NEAR(j["periodic"][0]["period_mm"].get<double>(), 55.0, 1.1);
  EXPECT_TRUE(j["periodic"][0].contains("amplitude_um"));
  EXPECT_LE(j["straightness_min_zone_um"].get<double>(),
            j["straightness_lsq_um"].get<double>() + 1e-12);
}

TEST_F(FormCli, StraightnessReversalPairAmongSeveralFiles) {
  const std::string a = Write("a.txt", StraightnessText("# reversal: a\n# pair_id: r1\n", 1.0, 2));
  const std::string c = Write("c.txt", StraightnessText("", 1.0, 3));
  const std::string b = Write("b.txt", StraightnessText("# reversal: b\n# pair_id: r1\n", -1.0, 4));
  const nlohmann::json j = Run("form straightness", {a, c, b});
  ASSERT_EQ(j["profiles"].size(), 3u);
  EXPECT_EQ(j["profiles"][0]["file"], a);
  EXPECT_EQ(j["profiles"][1]["file"], c);
  EXPECT_EQ(j["profiles"][2]["file"], b);
  EXPECT_TRUE(j["profiles"][1].contains("straightness_lsq_um"));
  EXPECT_FALSE(j["profiles"][1].contains("reversal"));
  const nlohmann::json& r = j["profiles"][0]["reversal"];
  EXPECT_EQ(r, j["profiles"][2]["reversal"]);
  EXPECT_EQ(r, j["reversal"]);
  EXPECT_EQ(r["pair_id"], "r1");
  EXPECT_EQ(r["reversal_setup"], "artefact");  // the default: the key is absent
  for (const char* k : {"positions_mm", "machine_um", "artefact_um", "machine_straightness_lsq_um",
                        "artefact_straightness_lsq_um"}) {
    EXPECT_TRUE(r.contains(k)) << k;
  }
  ASSERT_EQ(r["positions_mm"].size(), 301u);
  // Machine = the 55 mm waviness (P-V 0.4 um), artefact = the bow (P-V 0.225 um).
  EXPECT_NEAR(r["machine_straightness_lsq_um"].get<double>(), 0.4, 0.05);
  for (std::size_t i = 0; i < 301; i += 25) {
    const double x = r["positions_mm"][i].get<double>();
    EXPECT_NEAR(r["machine_um"][i].get<double>(), 0.2 * std::cos(2.0 * std::numbers::pi * x / 55.0),
                0.04);
    EXPECT_NEAR(r["artefact_um"][i].get<double>(), 1e-5 * (x - 150.0) * (x - 150.0), 0.04);
  }
  // Two `a` profiles in one pair is bad input naming the second file.
  const std::string a2 =
      Write("a2.txt", StraightnessText("# reversal: a\n# pair_id: r1\n", 1.0, 5));
  Args args;
  args.positional = {a, a2};
  std::ostringstream out;
  try {
    Registry().at("form straightness").run(args, out);
    ADD_FAILURE() << "no InvalidInput";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), a2);
    EXPECT_EQ(e.field(), "reversal");
    EXPECT_EQ(e.line(), 7u);
  }
}

const char kSensorReversedPair[] = "# pair_id: e1\n# reversal_setup: artefact_and_sensor\n";

// Set-up b with the sensor moved to the other side as well: b = -machine + artefact.
TEST_F(FormCli, StraightnessReversalWithTheSensorReversedToo) {
  const std::string head = kSensorReversedPair;
  const std::string a = Write("ea.txt", StraightnessText("# reversal: a\n" + head, 1.0, 6));
  const std::string b = Write("eb.txt", StraightnessText("# reversal: b\n" + head, 1.0, 7, -1.0));
  const nlohmann::json j = Run("form straightness", {a, b});
  const nlohmann::json& r = j["reversal"];
  EXPECT_EQ(r["reversal_setup"], "artefact_and_sensor");
  EXPECT_EQ(r["convention"], "a = machine + artefact, b = -machine + artefact");
  EXPECT_EQ(j["profiles"][1]["measurement"]["reversal_setup"], "artefact_and_sensor");
  double worst_m = 0.0, worst_a = 0.0;
  for (std::size_t i = 0; i < r["positions_mm"].size(); ++i) {
    const double x = r["positions_mm"][i].get<double>();
    worst_m = std::max(worst_m, std::abs(r["machine_um"][i].get<double>() -
                                         0.2 * std::cos(2.0 * std::numbers::pi * x / 55.0)));
    worst_a = std::max(
        worst_a, std::abs(r["artefact_um"][i].get<double>() - 1e-5 * (x - 150.0) * (x - 150.0)));
  }
  std::printf(
      "[ measured ] CLI artefact_and_sensor pair, noise 0.01 um: machine %.4f um, "
      "artefact %.4f um; P-V machine %.4f um, artefact %.4f um\n",
      worst_m, worst_a, r["machine_straightness_lsq_um"].get<double>(),
      r["artefact_straightness_lsq_um"].get<double>());
  // Noise 0.01 um a reading: 0.007 um a separated value, worst of 301 below 0.04 um.
  EXPECT_LT(worst_m, 0.04);
  EXPECT_LT(worst_a, 0.04);
  // Machine = the 55 mm waviness (P-V 0.4 um), artefact = the bow (P-V 0.225 um).
  EXPECT_NEAR(r["machine_straightness_lsq_um"].get<double>(), 0.4, 0.05);
  EXPECT_NEAR(r["artefact_straightness_lsq_um"].get<double>(), 0.225, 0.05);
}

// The two files of a pair must state the same set-up; the later file (input order) is named.
TEST_F(FormCli, StraightnessReversalPairMustStateOneSetUp) {
  const std::string head = kSensorReversedPair;
  const std::string a = Write("ea.txt", StraightnessText("# reversal: a\n" + head, 1.0, 6));
  const std::string b_default =
      Write("eb0.txt", StraightnessText("# reversal: b\n# pair_id: e1\n", -1.0, 8));
  const std::string b_other = Write(
      "eb1.txt",
      StraightnessText("# reversal: b\n# pair_id: e1\n# reversal_setup: artefact\n", -1.0, 9));
  const std::vector<std::tuple<std::vector<std::string>, std::string, std::size_t>> cases{
      {{a, b_default}, b_default, 7u},  // key absent (default artefact): the reversal line
      {{a, b_other}, b_other, 9u},
      {{b_other, a}, a, 9u}};
  for (const auto& [files, file, line] : cases) {
    Args args;
    args.positional = files;
    std::ostringstream out;
    try {
      Registry().at("form straightness").run(args, out);
      ADD_FAILURE() << "no InvalidInput";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.file(), file);
      EXPECT_EQ(e.line(), line);
      EXPECT_EQ(e.field(), "reversal_setup");
      EXPECT_NE(e.reason().find("same set-up"), std::string::npos) << e.reason();
    }
  }
}

TEST_F(FormCli, FlatnessAndParallelismKeys) {
  std::ostringstream flat;
  flat << "# format: kinemetric-flatness/1\n# machine_id: pm600\n# datum: table\nx_mm,y_mm,z_um\n";
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) {
      const double x = -190 + 95 * i, y = -190 + 95 * j;
      flat << x << "," << y << "," << 0.1 * x - 0.05 * y + (i == 2 && j == 2 ? 7.0 : 0.0) << "\n";
    }
  }
  const nlohmann::json f = Run("form flatness", {Write("f.txt", flat.str())});
  for (const char* k : {"flatness_lsq_um", "flatness_min_zone_um", "range_um", "plane"}) {
    EXPECT_TRUE(f.contains(k)) << k;
  }
  EXPECT_NEAR(f["flatness_min_zone_um"].get<double>(), 7.0, 1e-9);
  EXPECT_NEAR(f["plane"]["slope_x_um_per_m"].get<double>(), 100.0, 1e-6);
  EXPECT_NEAR(f["plane"]["slope_y_um_per_m"].get<double>(), -50.0, 1e-6);
  EXPECT_TRUE(f["plane"].contains("offset_um"));
  EXPECT_EQ(f["reference"], "least_squares_plane");

  const std::string par =
      "# format: kinemetric-parallelism/1\n# machine_id: pm600\n# axis: X\n# datum: t_slot\n"
      "position_mm,deviation_um\n-190,0\n-95,4\n0,12\n95,14\n190,19\n";
  const nlohmann::json p = Run("form parallelism", {Write("p.txt", par)});
  EXPECT_DOUBLE_EQ(p["parallelism_um"].get<double>(), 19.0);
  EXPECT_DOUBLE_EQ(p["length_mm"].get<double>(), 380.0);
  // Least-squares slope of the five points (mean position 0): sum(x d) / sum(x^2)
  // = (-95*4 + 95*14 + 190*19) / (2 * (190^2 + 95^2)) = 4560 / 90250 um/mm.
  EXPECT_NEAR(p["slope_um_per_m"].get<double>(), 1000.0 * 4560.0 / 90250.0, 1e-9);
  EXPECT_EQ(p["reference"], "datum");
}

TEST_F(FormCli, BadInputIsInvalidInput) {
  Args args;
  std::ostringstream out;
  EXPECT_THROW(Registry().at("form straightness").run(args, out), InvalidInput);
  args.positional = {Write("x.txt",
                           "# format: kinemetric-flatness/1\n# machine_id: m\n"
                           "x_mm,y_mm,z_um\n0,0,1\n1,0,1\n0,1,oops\n")};
  try {
    Registry().at("form flatness").run(args, out);
    ADD_FAILURE() << "no InvalidInput";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.line(), 6u);
    EXPECT_EQ(e.field(), "z_um");
  }
  args.positional = {(dir_ / "missing.txt").string()};
  EXPECT_THROW(Registry().at("form parallelism").run(args, out), InvalidInput);
}

}  // namespace
}  // namespace km::cli
