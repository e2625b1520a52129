// Shared by the hexapod effect and discovery tests: the reference machine's gravity and
// friction blocks and simulated absolute test sets with hidden effects (evaluated by the
// simulator through the effect registry; the independent simulator is tests/sim/).
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "analysis/hexapod/effects/registry.h"
#include "analysis/sim/hexapod_dbb_sim.h"
#include "tests/unit/hexapod/pm600_fixture.h"

namespace km::hexapod::test {

// The gravity and friction blocks of the reference machine file.
inline MachinePhysics Pm600Physics() {
  MachinePhysics m;
  m.has_gravity = true;
  m.g_m_s2 = Eigen::Vector3d(0, 0, -9.80665);
  m.platform_mass_kg = 250.0;
  m.platform_cog_mm = Eigen::Vector3d(0, 0, 180.0);
  m.ball_screw_mass_kg = 12.0;
  m.joint_mass_kg = 6.0;
  m.motor_mass_kg = 18.0;
  m.motor_offset_mm = 100.0;
  m.platform_joint_length_mm = 150.0;
  m.ball_screw_length_mm = 1000.0;
  m.strut_equivalent_mass_kg = 27.0;
  m.compliance_screw_mm_per_N = 9e-6;
  m.compliance_other_mm_per_N = 1.52e-5;
  m.has_friction = true;
  m.base_joint_torque_Nm = 8.88;
  m.base_joint_torque_per_N_m = 0.0139;
  return m;
}

// One DBB circle of the jig plan's kind (R 150 mm, centre (0, 0, −1050), 1000 mm/min, tool
// 104.255 mm) with zero deviations: n samples over `arc_deg` from `start_deg`, tilt A.
inline dbb::DbbTest CircleTest(dbb::Direction dir, int n, double arc_deg = 360.0,
                               double tilt_a_deg = 0.0, double start_deg = 0.0) {
  dbb::DbbTest t;
  t.test_id = "t";
  t.direction = dir;
  t.bar_length_mm = 150.0;
  t.radius_mm = 150.0;
  t.centre_mm = {0, 0, -1050};
  t.tilt_deg = {tilt_a_deg, 0, 0};
  t.feed_mm_min = 1000.0;
  t.tool_length_mm = 104.255;
  const double sign = dir == dbb::Direction::kCw ? -1.0 : 1.0;
  const double step = arc_deg / (arc_deg >= 360.0 ? n : n - 1);
  for (int k = 0; k < n; ++k) {
    t.angle_deg.push_back(start_deg + sign * step * k);
    t.dr_um.push_back(0.0);
  }
  return t;
}

// A simulated absolute test set with hidden effects (the effects evaluated by the simulator
// through the registry; the independent simulator is tests/sim/hexapod_truth.py).
struct Scenario {
  HexapodGeometry nominal = Pm600Like();
  MachinePhysics phys = Pm600Physics();
  std::vector<dbb::DbbTest> tests;
  std::vector<std::optional<double>> starts;
};

inline Scenario Simulate(
    const std::vector<std::pair<std::string, std::vector<std::pair<int, double>>>>& effects,
    bool both_directions = true, int samples = 180, std::uint32_t seed = 7,
    double platform_joint_error_mm = 0.0) {
  Scenario s;
  auto plan = sim::Table21Plan(samples, both_directions);
  for (std::size_t i = 0; i < plan.size(); ++i) {
    plan[i].tool_length_mm = i < plan.size() / 2 ? 104.255 : 150.0;
    plan[i].start_time_s = 150.0 * static_cast<double>(i);
    s.starts.push_back(plan[i].start_time_s);
  }
  sim::HexapodDbbSimOptions opt;
  opt.absolute = true;
  opt.noise_um = 0.3;
  opt.physics = &s.phys;
  opt.seed = seed;
  EffectSetup setup;
  setup.physics = &s.phys;
  setup.all_timed = true;
  setup.tool_lengths_mm = {104.255, 150.0};
  for (const auto& [name, values] : effects) {
    const auto* e = FindHexapodEffect(name);
    ActiveEffect a{e, e->Parameters(setup)};
    for (const auto& [i, v] : values) a.params[static_cast<std::size_t>(i)].value = v;
    opt.effects.push_back(a);
  }
  auto truth = sim::PerturbGeometry(s.nominal, 0.3, 0.1, seed);
  // Platform joints off their nominal places: outside the 24-parameter kinematic model.
  for (int j = 0; j < 6; ++j)
    for (int k = 0; k < 3; ++k)
      truth.platform_joints_mm[j][k] +=
          platform_joint_error_mm * std::sin(1.7 * (3 * j + k) + seed);
  s.tests = sim::SimulateHexapodDbbPlan(s.nominal, truth, plan, opt);
  return s;
}

}  // namespace km::hexapod::test
