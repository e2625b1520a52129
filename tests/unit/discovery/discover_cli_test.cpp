// `kinemetric discover` run through the command registry (cli/cmd_discover.cpp and
// cmd_simulate.cpp are compiled into this test) on DBB files written with the product's writer:
// docs/formats.md §3 keys, the hidden effects found, a hexapod set written by `simulate dbb` run
// through the hexapod family, bad files rejected (exit 2).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/dbb/serial_sim.h"
#include "cli/command.h"
#include "ingest/dbb_writer.h"
#include "tests/unit/cli_test_fixture.h"

namespace km::cli {
namespace {

using serial_effects::EffectId;

std::set<std::string> Keys(const nlohmann::json& j) {
  std::set<std::string> k;
  for (const auto& [key, v] : j.items()) k.insert(key);
  return k;
}

class DiscoverCli : public test::CliTest {
 protected:
  // A cw + ccw pair at 1000 mm/min of a machine with squareness, servo mismatch, backlash.
  std::vector<std::string> WritePair(unsigned seed) {
    std::vector<std::string> files;
    for (auto d : {dbb::Direction::kCcw, dbb::Direction::kCw}) {
      dbb::SerialDbbSimOptions o;
      o.seed = seed + (d == dbb::Direction::kCw ? 1000u : 0u);
      o.direction = d;
      o.noise_um = 0.2;
      o.step_deg = 0.2;
      o.effects = {{EffectId::kSquareness, {15.0}},
                   {EffectId::kServoMismatch, {1.0}},
                   {EffectId::kBacklashU, {3.0}}};
      files.push_back(Write(std::string("t1_") + dbb::ToString(d) + ".dbb",
                            ingest::WriteDbb(dbb::SimulateSerialDbbTest(o))));
    }
    return files;
  }
};

TEST_F(DiscoverCli, JsonHasTheContractKeysAndFindsTheEffects) {
  for (unsigned seed : {3u, 4u}) {
    std::ostringstream out;
    ASSERT_EQ(Registry().at("discover").run(JsonArgs(WritePair(seed)), out), 0);
    const auto j = nlohmann::json::parse(out.str());
    for (const char* k : {"steps", "final_model", "unexplained_rms_um", "noise_floor_um"})
      ASSERT_TRUE(j.contains(k)) << k;
    ASSERT_TRUE(j["steps"].is_array());
    ASSERT_TRUE(j["final_model"].is_array());
    EXPECT_TRUE(j["unexplained_rms_um"].is_number());
    EXPECT_TRUE(j["noise_floor_um"].is_number());
    std::set<std::string> added;
    for (const auto& s : j["steps"]) {
      EXPECT_EQ(Keys(s), (std::set<std::string>{"added_effect", "evidence", "gap_rms_before_um",
                                                "gap_rms_after_um"}));
      ASSERT_TRUE(s["evidence"].is_object());
      for (const char* k : {"rss_before_um2", "rss_after_um2", "f_statistic", "p_value", "value",
                            "unit", "sigma", "parameters", "runner_up", "runner_up_rss_drop_um2"})
        EXPECT_TRUE(s["evidence"].contains(k)) << k;
      EXPECT_LT(s["gap_rms_after_um"].get<double>(), s["gap_rms_before_um"].get<double>());
      added.insert(s["added_effect"].get<std::string>());
    }
    EXPECT_EQ(added, (std::set<std::string>{"squareness", "servo_mismatch", "backlash_x"}));
    std::set<std::string> names;
    for (const auto& m : j["final_model"]) {
      for (const char* k : {"effect", "value", "unit", "sigma"}) EXPECT_TRUE(m.contains(k)) << k;
      names.insert(m["effect"].get<std::string>());
      if (m["effect"] == "squareness") {
        EXPECT_EQ(m["unit"], "um/m");
        EXPECT_NEAR(m["value"].get<double>(), 15.0, 0.75);
      }
      if (m["effect"] == "servo_mismatch") {
        EXPECT_EQ(m["unit"], "ms");
        EXPECT_NEAR(m["value"].get<double>(), 1.0, 0.05);
      }
      if (m["effect"] == "backlash_x") {
        EXPECT_NEAR(m["value"].get<double>(), 3.0, 0.15);
      }
      if (m["effect"] == "centre_offset") {
        EXPECT_EQ(m["value"].size(), 2u);
      }
    }
    EXPECT_TRUE(names.count("centre_offset") && names.count("radius_error"));
    EXPECT_NEAR(j["unexplained_rms_um"].get<double>(), 0.2, 0.03);
    EXPECT_NEAR(j["noise_floor_um"].get<double>(), 0.2, 0.03);
  }
}

TEST_F(DiscoverCli, SerialMachineFileIsAccepted) {
  const std::string m =
      Write("serial.json",
            R"({"format": "kinemetric-machine/1", "machine_id": "sim-serial", "kind": "serial"})");
  Args args = JsonArgs(WritePair(5));
  args.options["--machine"] = m;
  std::ostringstream out;
  ASSERT_EQ(Registry().at("discover").run(args, out), 0);
  EXPECT_EQ(nlohmann::json::parse(out.str())["steps"].size(), 3u);
}

TEST_F(DiscoverCli, HexapodMachineRunsTheHexapodFamily) {
  // A set written by `kinemetric simulate dbb --absolute --effects gravity_deflection:…` (15
  // tests × cw/ccw of the example machine, 180 samples a turn to keep the test short) is read
  // back by `kinemetric discover --machine`: the hexapod family names the gravity deflection.
  const std::string machine = KINEMETRIC_SOURCE_DIR "/tests/fixtures/pm600-like.json";
  Args sim;
  sim.options["--machine"] = machine;
  sim.options["--out"] = (dir_ / "sim").string();
  sim.options["--absolute"] = "";
  sim.options["--effects"] = "gravity_deflection:K_stiff2_mm_per_N=1.52e-5";
  sim.options["--samples"] = "180";
  sim.options["--json"] = "";
  sim.json = true;
  std::ostringstream sim_out;
  ASSERT_EQ(Registry().at("simulate dbb").run(sim, sim_out), 0);
  const auto written = nlohmann::json::parse(sim_out.str());
  std::vector<std::string> files;
  for (const auto& f : written["files"]) files.push_back(f.get<std::string>());
  ASSERT_FALSE(files.empty());
  Args args = JsonArgs(files);
  args.options["--machine"] = machine;
  std::ostringstream out;
  ASSERT_EQ(Registry().at("discover").run(args, out), 0);
  const auto j = nlohmann::json::parse(out.str());
  EXPECT_EQ(j["kind"], "hexapod");
  std::set<std::string> added;
  for (const auto& s : j["steps"]) added.insert(s["added_effect"].get<std::string>());
  EXPECT_TRUE(added.count("gravity_deflection")) << j["steps"].dump();
  EXPECT_EQ(j["verdict"], "complete") << j["stop_reason"];
}

TEST_F(DiscoverCli, BadFileIsBadInputNamingTheFile) {
  const std::string bad =
      Write("bad.dbb", "# format: kinemetric-dbb/1\n# machine_id: m\nangle_deg,dr_um\n0,1\n");
  try {
    std::ostringstream out;
    Registry().at("discover").run(JsonArgs({WritePair(7)[0], bad}), out);
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("bad.dbb"), std::string::npos) << e.what();
  }
  const std::string tracker = Write("t.txt", "# format: kinemetric-tracker/1\n");
  std::ostringstream out;
  EXPECT_THROW(Registry().at("discover").run(JsonArgs({tracker}), out), InvalidInput);
  EXPECT_THROW(Registry().at("discover").run(JsonArgs({}), out), InvalidInput);
  EXPECT_THROW(Registry().at("discover").run(JsonArgs({(dir_ / "missing.dbb").string()}), out),
               InvalidInput);
}

}  // namespace
}  // namespace km::cli
