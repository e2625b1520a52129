// Machine-definition JSON (docs/formats.md §2) and DBB writer (docs/formats.md §1.1) round trips: a
// simulated test written with WriteDbb and read back with the product's parser is the same test, to
// 1e-6 µm; a machine written back keeps its geometry and every other key; errors name the field.
#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "analysis/sim/hexapod_dbb_sim.h"
#include "ingest/dbb_parser.h"
#include "ingest/dbb_writer.h"
#include "ingest/machine_json.h"
#include "tests/unit/hexapod/pm600_fixture.h"

namespace km::ingest {
namespace {

std::string Pm600Json() {
  nlohmann::json j;
  j["format"] = "kinemetric-machine/1";
  j["machine_id"] = "pm600-like";
  j["kind"] = "hexapod";
  const auto g = hexapod::test::Pm600Like();
  for (int k = 0; k < 6; ++k) {
    j["base_joints_mm"].push_back(
        {g.base_joints_mm[k].x(), g.base_joints_mm[k].y(), g.base_joints_mm[k].z()});
    j["platform_joints_mm"].push_back(
        {g.platform_joints_mm[k].x(), g.platform_joints_mm[k].y(), g.platform_joints_mm[k].z()});
  }
  j["strut_offset_mm"] = {0, 0, 0, 0, 0, 0};
  j["gravity"] = {{"platform_mass_kg", 250.0}};
  j["friction"] = {{"base_joint_torque_Nm", 8.88}};
  return j.dump(2);
}

TEST(HexapodIo, MachineJsonParsesAndRoundTrips) {
  const auto m = ParseHexapodMachineJson(Pm600Json(), "pm600.json");
  EXPECT_EQ(m.machine_id, "pm600-like");
  const auto g = hexapod::test::Pm600Like();
  for (int j = 0; j < 6; ++j) {
    EXPECT_EQ(m.geometry.base_joints_mm[j], g.base_joints_mm[j]);
    EXPECT_EQ(m.geometry.platform_joints_mm[j], g.platform_joints_mm[j]);
  }
  auto changed = m;
  changed.geometry = sim::PerturbGeometry(g, 0.3, 0.1, 5);
  const std::string out = WriteMachineJson(changed);
  const auto back = ParseHexapodMachineJson(out, "out.json");
  for (int j = 0; j < 6; ++j) {
    EXPECT_EQ(back.geometry.base_joints_mm[j], changed.geometry.base_joints_mm[j]);  // exact
    EXPECT_EQ(back.geometry.strut_offset_mm[j], changed.geometry.strut_offset_mm[j]);
  }
  const auto doc = nlohmann::json::parse(out);
  EXPECT_DOUBLE_EQ(doc["gravity"]["platform_mass_kg"].get<double>(), 250.0);
  EXPECT_DOUBLE_EQ(doc["friction"]["base_joint_torque_Nm"].get<double>(), 8.88);
}

TEST(HexapodIo, MachineJsonErrorsNameTheField) {
  auto expect_field = [](const std::string& text, const std::string& field) {
    try {
      (void)ParseHexapodMachineJson(text, "m.json");
      ADD_FAILURE() << "accepted: " << field;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), field) << e.what();
      EXPECT_EQ(e.file(), "m.json");
    }
  };
  auto doc = nlohmann::json::parse(Pm600Json());
  auto bad = doc;
  bad["base_joints_mm"][2][1] = "x";
  expect_field(bad.dump(), "base_joints_mm[2][1]");
  bad = doc;
  bad["platform_joints_mm"].erase(5);
  expect_field(bad.dump(), "platform_joints_mm");
  bad = doc;
  bad.erase("base_joints_mm");
  expect_field(bad.dump(), "base_joints_mm");
  bad = doc;
  bad["strut_offset_mm"][3] = nullptr;
  expect_field(bad.dump(), "strut_offset_mm[3]");
  bad = doc;
  bad["format"] = "kinemetric-machine/2";
  expect_field(bad.dump(), "format");
  bad = doc;
  bad["kind"] = "serial";
  expect_field(bad.dump(), "kind");
  expect_field("{not json", "");
}

TEST(HexapodIo, MachineJsonRefusesNumbersBeyondDouble) {
  // The JSON reader reports a number that overflows a double as out of range, not as a syntax
  // error; both are bad input.
  for (const char* text : {"6e400", R"({"format": -1e999})"}) {
    try {
      (void)ParseMachineJson(text, "m.json");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.file(), "m.json");
      EXPECT_NE(std::string(e.what()).find("does not fit a double"), std::string::npos) << e.what();
    }
  }
}

TEST(HexapodIo, DbbWriterRoundTripsThroughTheParser) {
  const auto g = hexapod::test::Pm600Like();
  const auto truth = sim::PerturbGeometry(g, 0.3, 0.1, 2);
  for (bool absolute : {true, false}) {
    sim::HexapodDbbSimOptions opt;
    opt.absolute = absolute;
    opt.noise_um = 0.3;
    for (const auto& spec : sim::Table21Plan(90, true)) {
      const auto t = sim::SimulateHexapodDbb(g, truth, spec, opt, 3);
      const auto back = ParseDbb(WriteDbb(t), "x.dbb");
      EXPECT_EQ(back.test_id, t.test_id);
      EXPECT_EQ(back.machine_id, t.machine_id);
      EXPECT_EQ(back.direction, t.direction);
      EXPECT_EQ(back.centre_mm, t.centre_mm);
      EXPECT_EQ(back.tilt_deg, t.tilt_deg);
      EXPECT_EQ(back.bar_length_mm, t.bar_length_mm);
      EXPECT_EQ(back.radius_mm, t.radius_mm);
      EXPECT_EQ(back.z_offset_mm, t.z_offset_mm);
      EXPECT_EQ(back.tool_length_mm, t.tool_length_mm);
      EXPECT_EQ(back.fixed_ball_mm.has_value(), absolute);
      if (absolute) {
        EXPECT_EQ(*back.fixed_ball_mm, *t.fixed_ball_mm);
      }
      ASSERT_EQ(back.dr_um.size(), t.dr_um.size());
      for (std::size_t i = 0; i < t.dr_um.size(); ++i) {
        EXPECT_NEAR(back.dr_um[i], t.dr_um[i], 0.5e-6 + 1e-12);
        EXPECT_NEAR(back.angle_deg[i], t.angle_deg[i], 0.5e-9 + 1e-12);
      }
    }
  }
}

}  // namespace
}  // namespace km::ingest
