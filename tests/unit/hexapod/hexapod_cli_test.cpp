// `kinemetric simulate dbb` and `kinemetric hexapod calibrate` run through the command registry
// (cli/cmd_simulate.cpp and cli/cmd_hexapod.cpp are compiled into this test): a noise-free
// absolute set of the example machine is written with known kinematic errors (the simulator's
// `true_parameters` and `--write-truth` machine), calibrated, and every observable parameter,
// the written machine and the post-calibration prediction are compared with that truth.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "ingest/dbb_parser.h"
#include "ingest/machine_json.h"
#include "tests/unit/cli_test_fixture.h"

namespace km::cli {
namespace {

constexpr const char* kMachine = KINEMETRIC_SOURCE_DIR "/data/machines/pm600-like.json";

class HexapodCli : public test::CliTest {
 protected:
  // `simulate dbb --absolute --noise-um 0`: the default plan, 180 samples a turn.
  nlohmann::json Simulate() {
    Args sim;
    sim.options["--machine"] = kMachine;
    sim.options["--out"] = (dir_ / "sim").string();
    sim.options["--absolute"] = "";
    sim.options["--noise-um"] = "0";
    sim.options["--seed"] = "5";
    sim.options["--samples"] = "180";
    sim.options["--write-truth"] = (dir_ / "truth.json").string();
    sim.options["--json"] = "";
    sim.json = true;
    std::ostringstream out;
    EXPECT_EQ(Registry().at("simulate dbb").run(sim, out), 0);
    return nlohmann::json::parse(out.str());
  }

  static std::vector<std::string> Files(const nlohmann::json& sim) {
    std::vector<std::string> files;
    for (const auto& f : sim["files"]) files.push_back(f.get<std::string>());
    return files;
  }
};

TEST_F(HexapodCli, CalibrateRecoversTheSimulatedKinematicErrors) {
  const nlohmann::json sim = Simulate();
  ASSERT_EQ(sim["mode"], "absolute");
  ASSERT_GE(sim["files"].size(), 24u);
  Args args = CliTest::JsonArgs(Files(sim));
  args.options["--machine"] = kMachine;
  args.options["--write-machine"] = (dir_ / "calibrated.json").string();
  std::ostringstream out;
  ASSERT_EQ(Registry().at("hexapod calibrate").run(args, out), 0);
  const auto j = nlohmann::json::parse(out.str());
  EXPECT_EQ(j["method"], "absolute");

  // Noise-free data: every observable parameter is recovered (µm); fixed ones are left at 0.
  std::set<std::string> fixed;
  for (const auto& f : j["fixed_parameters"]) fixed.insert(f.get<std::string>());
  const auto& truth = sim["true_parameters"];
  const auto& got = j["parameters"];
  int compared = 0;
  for (int s = 0; s < 6; ++s) {
    const std::string name = "strut_offset_um[" + std::to_string(s) + "]";
    if (fixed.count(name)) continue;
    EXPECT_NEAR(got["strut_offset_um"][s].get<double>(), truth["strut_offset_um"][s].get<double>(),
                0.05)
        << name;
    ++compared;
    for (int c = 0; c < 3; ++c) {
      const std::string b =
          "base_joint_offset_um[" + std::to_string(s) + "][" + std::to_string(c) + "]";
      if (fixed.count(b)) continue;
      EXPECT_NEAR(got["base_joint_offset_um"][s][c].get<double>(),
                  truth["base_joint_offset_um"][s][c].get<double>(), 0.05)
          << b;
      ++compared;
    }
  }
  EXPECT_GE(compared, 18);
  EXPECT_LT(j["residual_rms_um"].get<double>(), 0.01);
  // After calibration every trace is predicted round (the data hold nothing else).
  const auto files = Files(sim);
  ASSERT_EQ(j["tests"].size(), files.size());
  for (std::size_t i = 0; i < files.size(); ++i) {
    const auto& t = j["tests"][i];
    EXPECT_LT(t["predicted_circularity_after_um"].get<double>(), 0.05) << t["test_id"];
    // The figures' units are stated: the bar's, as [PM-600 report] eq. 4.8, with the factor to
    // tool-path units (bar length / circle radius: 150/144 on the plan's cone tests).
    const auto test = ingest::ParseDbb(ReadFileBytes(files[i]), files[i]);
    EXPECT_EQ(t["deviation_units"], "bar") << t["test_id"];
    EXPECT_DOUBLE_EQ(t["bar_to_tool_path_factor"].get<double>(),
                     test.bar_length_mm / test.radius_mm)
        << t["test_id"];
  }

  // The written machine has the true geometry where it is observable: compare base joints.
  const auto calibrated = ingest::ParseHexapodMachineJson(
      ReadFileBytes((dir_ / "calibrated.json").string()), "calibrated.json");
  const auto true_machine =
      ingest::ParseHexapodMachineJson(ReadFileBytes((dir_ / "truth.json").string()), "truth.json");
  for (int s = 0; s < 6; ++s) {
    EXPECT_NEAR(calibrated.geometry.strut_offset_mm[s], true_machine.geometry.strut_offset_mm[s],
                1e-4);
  }
}

TEST_F(HexapodCli, TextOutputAndBadMethod) {
  const nlohmann::json sim = Simulate();
  Args args;
  args.positional = Files(sim);
  args.options["--machine"] = kMachine;
  std::ostringstream out;
  ASSERT_EQ(Registry().at("hexapod calibrate").run(args, out), 0);
  EXPECT_EQ(out.str().rfind("method absolute, residual rms ", 0), 0u) << out.str();
  EXPECT_NE(out.str().find("strut 6 offset"), std::string::npos);

  args.options["--method"] = "sideways";
  EXPECT_THROW(Registry().at("hexapod calibrate").run(args, out), InvalidInput);
  Args no_files;
  no_files.options["--machine"] = kMachine;
  EXPECT_THROW(Registry().at("hexapod calibrate").run(no_files, out), InvalidInput);
}

}  // namespace
}  // namespace km::cli
