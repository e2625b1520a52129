// The pm600-like machine of data/machines/pm600-like.json for the servo tests, and the jig plan
// simulated by the independent simulator (servo_truth.h) and read back by the parser.
#pragma once

#include <random>
#include <vector>

#include "analysis/hexapod/statics.h"
#include "analysis/servo/servo_types.h"
#include "ingest/servo_parser.h"
#include "tests/unit/servo/servo_truth.h"

namespace km::servo::test {

inline hexapod::HexapodGeometry Pm600Geometry() {
  const truth::Machine m = truth::Pm600Truth();
  hexapod::HexapodGeometry g;
  g.base_joints_mm = m.base;
  g.platform_joints_mm = m.platform;
  return g;
}

inline hexapod::MachinePhysics Pm600Physics() {
  hexapod::MachinePhysics p;
  p.has_gravity = p.has_friction = true;
  p.platform_mass_kg = 250.0;
  p.platform_cog_mm = Eigen::Vector3d(0, 0, 180.0);
  p.ball_screw_mass_kg = 12.0;
  p.joint_mass_kg = 6.0;
  p.motor_mass_kg = 18.0;
  p.motor_offset_mm = 100.0;
  p.platform_joint_length_mm = 150.0;
  p.ball_screw_length_mm = 1000.0;
  p.strut_equivalent_mass_kg = 27.0;
  p.screw_friction_N = {151, 164, 219, 201, 182, 136};
  p.base_joint_torque_Nm = 8.88;
  p.base_joint_torque_per_N_m = 0.0139;
  return p;
}

inline std::vector<ServoFile> SimulateCircles(const truth::Machine& m,
                                              const std::vector<truth::Circle>& circles,
                                              double noise_N, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<ServoFile> files;
  for (auto c : circles) {
    for (bool ccw : {true, false}) {
      c.ccw = ccw;
      const auto rec = truth::Simulate(m, c, noise_N, rng);
      const std::string name = c.test_id + (ccw ? "_ccw" : "_cw") + ".txt";
      files.push_back(ingest::ParseServoFile(truth::ServoText(c, rec), name));
    }
  }
  return files;
}

inline std::vector<ServoFile> SimulatePlan(const truth::Machine& m, double noise_N, int samples,
                                           unsigned seed) {
  return SimulateCircles(m, truth::JigPlan(samples), noise_N, seed);
}

}  // namespace km::servo::test
