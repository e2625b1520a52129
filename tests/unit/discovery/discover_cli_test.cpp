// `kinemetric discover` run through the command registry (cli/cmd_discover.cpp is compiled into
// this test) on DBB files written with the product's writer: contract §3 keys, the hidden
// effects found, hexapod machines refused (exit 1), bad files rejected (exit 2).
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

using effects::EffectId;

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

TEST_F(DiscoverCli, HexapodMachineIsRefusedWithExitOne) {
  // main maps km::Error that is not km::InvalidInput to exit status 1 (cli/command.h).
  Args args = JsonArgs(WritePair(6));
  args.options["--machine"] = KINEMETRIC_SOURCE_DIR "/tests/fixtures/pm600-like.json";
  std::ostringstream out;
  try {
    Registry().at("discover").run(args, out);
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    FAIL() << "bad-input error (exit 2) instead of exit 1: " << e.what();
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("hexapod discovery"), std::string::npos) << what;
    EXPECT_NE(what.find("not available yet"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  EXPECT_TRUE(out.str().empty());
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
