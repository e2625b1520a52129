// `kinemetric servo identify | force | joints | feed-drive --json` run in-process on files of the
// independent simulator: the documented keys (docs/formats.md §3.10–3.13), the values, the
// machine written back, and bad input named.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "ingest/machine_json.h"
#include "tests/unit/cli_test_fixture.h"
#include "tests/unit/servo/feed_truth.h"
#include "tests/unit/servo/servo_truth.h"

namespace km::cli {
namespace {

const char* kMachine = "data/machines/pm600-like.json";

class ServoCli : public test::CliTest {
 protected:
  static nlohmann::json Run(const std::string& command, std::vector<std::string> files,
                            std::map<std::string, std::string> options = {}) {
    Args args = JsonArgs(std::move(files));
    args.options["--machine"] = kMachine;
    for (const auto& [k, v] : options) args.options[k] = v;
    std::ostringstream out;
    EXPECT_EQ(Registry().at(command).run(args, out), 0);
    return nlohmann::json::parse(out.str());
  }

  // The jig plan, both directions, 360 samples a circle.
  std::vector<std::string> Plan(const servo::truth::Machine& m, unsigned seed,
                                Eigen::Vector3d load = Eigen::Vector3d::Zero(), int tests = 15) {
    std::mt19937 rng(seed);
    std::vector<std::string> files;
    int k = 0;
    for (auto c : servo::truth::JigPlan(360)) {
      if (k++ >= tests) break;
      c.external_N = load;
      for (bool ccw : {true, false}) {
        c.ccw = ccw;
        files.push_back(Write(c.test_id + (ccw ? "_ccw.txt" : "_cw.txt"),
                              servo::truth::ServoText(c, servo::truth::Simulate(m, c, 2.0, rng))));
      }
    }
    return files;
  }
};

TEST_F(ServoCli, IdentifyPrintsTheMachineKeysAndWritesTheMachine) {
  // Joint friction of eq. 3.11 away from the machine file's t0 8.88 N·m, t1 0.0139 m.
  auto m = servo::truth::Pm600Truth();
  m.t0 = 10.2;
  m.t1 = 0.0121;
  const std::string out = (dir_ / "identified.json").string();
  const auto j = Run("servo identify", Plan(m, 1), {{"--write-machine", out}});
  for (const char* k : {"identified", "uncertainty"}) {
    for (const char* key :
         {"platform_mass_kg", "platform_cog_mm", "strut_equivalent_mass_kg", "motor_mass_kg",
          "screw_friction_N", "base_joint_torque_Nm", "base_joint_torque_per_N_m"}) {
      EXPECT_TRUE(j[k].contains(key)) << k << "." << key;
    }
  }
  EXPECT_EQ(j["residual_rms_N"].size(), 6u);
  EXPECT_LT(j["condition_number"].get<double>(), 100.0);  // the plan separates every parameter
  EXPECT_TRUE(j["fixed"].is_array());
  EXPECT_NEAR(j["identified"]["platform_mass_kg"].get<double>(), m.m_platform, 5.0);
  EXPECT_NEAR(j["identified"]["screw_friction_N"][2].get<double>(), m.f0[2], 5.0);
  const auto machine = ingest::ParseHexapodMachineJson(ReadFileBytes(out), out);
  ASSERT_TRUE(machine.physics.has_value());
  EXPECT_NEAR(machine.physics->platform_mass_kg, m.m_platform, 5.0);
  EXPECT_NEAR(machine.physics->base_joint_torque_Nm, m.t0, 0.1 * m.t0);
  EXPECT_NEAR(machine.physics->base_joint_torque_per_N_m, m.t1, 0.1 * m.t1);
  // The joint friction is a known effect of the written model (docs/hexapod-effects.md).
  ASSERT_EQ(machine.effects.size(), 1u);
  EXPECT_EQ(machine.effects[0].effect, "joint_friction");
  std::map<std::string, double> p(machine.effects[0].parameters.begin(),
                                  machine.effects[0].parameters.end());
  EXPECT_NEAR(p.at("torque_Nm"), m.t0, 0.1 * m.t0);
  EXPECT_NEAR(p.at("torque_per_N_m"), m.t1, 0.1 * m.t1);
  EXPECT_NEAR(p.at("ramp_mm"), m.joint_ramp_mm, 0.15);
  EXPECT_NEAR(j["joint_friction"]["ramp_mm"].get<double>(), m.joint_ramp_mm, 0.15);
}

TEST_F(ServoCli, ForceGivesAForcePerSampleWithItsUncertainty) {
  const auto m = servo::truth::Pm600Truth();
  const auto files = Plan(m, 2, Eigen::Vector3d(0.0, 250.0, 0.0), 1);
  const auto j = Run("servo force", {files[0]});
  ASSERT_EQ(j["t_s"].size(), 360u);
  ASSERT_EQ(j["force_N"].size(), 360u);
  ASSERT_EQ(j["sigma_N"].size(), 360u);
  EXPECT_EQ(j["force_N"][0].size(), 3u);
  EXPECT_NEAR(j["mean_force_N"][1].get<double>(), 250.0, 10.0);
  EXPECT_NEAR(j["mean_force_N"][0].get<double>(), 0.0, 10.0);
}

TEST_F(ServoCli, JointsGradeTheStiffLegAndReadThePrevious) {
  auto m = servo::truth::Pm600Truth();
  m.leg_factor[4] = 3.0;
  const auto files = Plan(m, 3);
  const auto j = Run("servo joints", files);
  ASSERT_EQ(j["legs"].size(), 6u);
  EXPECT_EQ(j["level"], 3);
  for (const auto& leg : j["legs"]) {
    for (const char* key : {"leg", "resistance_Nm", "sigma_Nm", "level", "evidence"}) {
      EXPECT_TRUE(leg.contains(key)) << key;
    }
    EXPECT_EQ(leg["level"], leg["leg"] == 5 ? 3 : 1) << leg["evidence"];
  }
  // The same data against itself as the previous estimate: no growth.
  const std::string prev = Write("previous.json", j.dump());
  const auto again = Run("servo joints", files, {{"--previous", prev}});
  EXPECT_EQ(again["legs"][0]["previous_Nm"], j["legs"][0]["resistance_Nm"]);
  EXPECT_EQ(again["legs"][0]["level"], 1);
}

TEST_F(ServoCli, FeedDriveWithTheDbbTestsOfTheMachine) {
  const auto j =
      Run("servo feed-drive", {"data/examples/servo_x-strokes.txt"},
          {{"--kp-per-s", "30"},
           {"--dbb", "data/examples/dbb_xy-r150_ccw.txt,data/examples/dbb_xy-r150_cw.txt"}});
  EXPECT_NEAR(j["coulomb_N"].get<double>(), 30.0, 1.5);
  EXPECT_NEAR(j["viscous_N_s_per_mm"].get<double>(), 0.05, 0.01);
  ASSERT_FALSE(j["ripple"].empty());
  EXPECT_NEAR(j["ripple"][0]["period_mm"].get<double>(), 55.0, 1.1);
  ASSERT_TRUE(j["lugre"].is_object());
  for (const char* k :
       {"Fc_N", "Fs_N", "vs_mm_s", "sigma0_N_per_um", "sigma1_N_s_per_mm", "sigma2_N_s_per_mm"}) {
    EXPECT_TRUE(j["lugre"].contains(k)) << k;
  }
  EXPECT_TRUE(j["stick_motion_um"].is_null());  // no radius and feed given
  ASSERT_EQ(j["dbb_comparison"].size(), 2u);
  EXPECT_EQ(j["dbb_comparison"][1]["direction"], "cw");
  EXPECT_GT(j["dbb_comparison"][0]["predicted_stick_motion_um"].get<double>(), 0.0);
  EXPECT_TRUE(j["dbb_comparison"][0]["measured"].is_array());
}

// Strokes at 10, 20 and 40 mm/s of the independent feed-drive simulator; `joined`: a second
// recording appended whose positions are 100 mm further, 2 ms after the first's last sample.
std::string FeedDriveText(bool joined) {
  namespace ft = servo::feed_truth;
  ft::Motion m = ft::BackAndForth(200.0, {10.0, 20.0, 40.0});
  m.accel_mm_s2 = 300.0;
  m.dwell_s = 0.5;
  const auto first = ft::Simulate(ft::Drive{}, m, 3);
  std::string text = ft::ServoText(first);
  if (!joined) return text;
  const auto second = ft::Simulate(ft::Drive{}, m, 4);
  char buf[96];
  for (std::size_t i = 0; i < second.t_s.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%.4f,%.7f,%.4f\n", first.t_s.back() + 2e-3 + second.t_s[i],
                  second.x_mm[i] + 100.0, second.force_N[i]);
    text += buf;
  }
  return text;
}

TEST_F(ServoCli, FeedDriveNamesTheLugreParametersItDetermines) {
  const auto j = Run("servo feed-drive", {Write("x.txt", FeedDriveText(false))});
  ASSERT_TRUE(j["lugre"].is_object()) << j.dump();
  ASSERT_TRUE(j["lugre_identifiable"].is_object()) << j.dump();
  for (const char* k :
       {"Fc_N", "Fs_N", "vs_mm_s", "sigma0_N_per_um", "sigma1_N_s_per_mm", "sigma2_N_s_per_mm"}) {
    ASSERT_TRUE(j["lugre_identifiable"][k].is_boolean()) << k;
    // A parameter is given with its σ exactly when it is identifiable.
    const bool ok = j["lugre_identifiable"][k].get<bool>();
    EXPECT_EQ(j["lugre"][k].is_number(), ok) << k;
    EXPECT_EQ(j["lugre_sigma"][k].is_number(), ok) << k;
    if (!ok) {
      EXPECT_NE(j["lugre_note"].get<std::string>().find(k), std::string::npos) << k;
    }
  }
  EXPECT_NEAR(j["lugre"]["sigma2_N_s_per_mm"].get<double>(), 0.05,
              3.0 * j["lugre_sigma"]["sigma2_N_s_per_mm"].get<double>());
  EXPECT_GT(j["steady_samples"].get<double>(), 0.8 * j["samples"].get<double>());
}

TEST_F(ServoCli, FeedDriveRefusesJoinedRecordingsNamingTheJump) {
  const std::string file = Write("joined.txt", FeedDriveText(true));
  const std::string single = FeedDriveText(false);
  const auto rows = static_cast<std::size_t>(std::count(single.begin(), single.end(), '\n'));
  try {
    Run("servo feed-drive", {file});
    ADD_FAILURE() << "accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), file);
    EXPECT_EQ(e.line(), rows + 1);  // the first row of the second recording
    EXPECT_EQ(e.field(), "pos_mm");
    EXPECT_NE(std::string(e.what()).find("jumps by 100.000 mm in 2.000 ms"), std::string::npos)
        << e.what();
  }
}

TEST_F(ServoCli, BadInputIsNamed) {
  const std::string bad = Write("bad.txt", "# format: kinemetric-servo/1\n# machine_id: x\n");
  try {
    Run("servo identify", {bad});
    ADD_FAILURE() << "accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), bad);
  }
  auto m = servo::truth::Pm600Truth();
  const auto files = Plan(m, 4, Eigen::Vector3d::Zero(), 1);
  const std::string prev = Write("previous.json", "{\"legs\": []}");
  try {
    Run("servo joints", files, {{"--previous", prev}});
    ADD_FAILURE() << "accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), prev);
    EXPECT_EQ(e.field(), "legs");
  }
  try {
    Run("servo feed-drive", files);
    ADD_FAILURE() << "accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), files[0]);
  }
}

}  // namespace
}  // namespace km::cli
