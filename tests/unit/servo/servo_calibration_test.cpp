// The joint friction identified from servo loads, written into the machine model as the
// `joint_friction` effect with known parameters, takes the friction out of a DBB calibration
// ([Joint patent] formulas 15–20, fig. 15): the kinematic parameters calibrated from CW tests
// and from CCW tests agree, where a friction-blind calibration makes them differ.
#include <algorithm>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "analysis/hexapod/effects/registry.h"
#include "analysis/servo/identify.h"
#include "analysis/sim/hexapod_dbb_sim.h"
#include "ingest/machine_json.h"
#include "ingest/servo_parser.h"
#include "tests/unit/servo/servo_truth.h"
#include "usecases/calibration_study.h"
#include "usecases/servo_report.h"

namespace km::servo {
namespace {

// Absolute DBB tests of the 15-test plan, both directions, of a machine whose kinematics differ
// from the model and whose base joints have the friction `joint_friction` (t0, ramp) with the
// model's t1, evaluated by the DBB simulator through the effect registry.
std::vector<dbb::DbbTest> DbbTests(const ingest::MachineDefinition& m, double t0, double ramp_mm) {
  auto plan = sim::Table21Plan(180, true);
  for (std::size_t i = 0; i < plan.size(); ++i) {
    plan[i].tool_length_mm = i < plan.size() / 2 ? 104.255 : 150.0;
    plan[i].start_time_s = 150.0 * static_cast<double>(i);
  }
  sim::HexapodDbbSimOptions opt;
  opt.absolute = true;
  opt.noise_um = 0.3;
  opt.physics = &*m.physics;
  opt.seed = 7;
  hexapod::EffectSetup setup;
  setup.physics = &*m.physics;
  setup.all_timed = true;
  setup.tool_lengths_mm = {104.255, 150.0};
  const auto* e = hexapod::FindHexapodEffect("joint_friction");
  hexapod::ActiveEffect a{e, e->Parameters(setup)};
  a.params[0].value = t0;
  a.params[1].value = ramp_mm;
  opt.effects.push_back(a);
  const auto truth = sim::PerturbGeometry(m.geometry, 0.3, 0.1, 7);
  return sim::SimulateHexapodDbbPlan(m.geometry, truth, plan, opt);
}

// Largest difference of the strut offsets calibrated from the CCW and from the CW tests, and
// the largest standard uncertainty of one.
std::pair<double, double> DirectionGap(const ingest::MachineDefinition& machine,
                                       const std::vector<dbb::DbbTest>& tests) {
  double gap = 0.0, sigma = 0.0;
  nlohmann::json p[2];
  for (int d = 0; d < 2; ++d) {
    usecases::CalibrationStudy study;
    study.machine = machine;
    for (const auto& t : tests) {
      if ((t.direction == dbb::Direction::kCcw) == (d == 0)) {
        study.tests.push_back(t);
        study.names.push_back(t.test_id);
      }
    }
    const auto out = usecases::RunCalibrationStudy(study);
    p[d] = out.report["parameters"]["strut_offset_um"];
    for (const auto& u : out.report["parameter_uncertainty_um"]["strut_offset_um"])
      sigma = std::max(sigma, u.get<double>());
  }
  for (int j = 0; j < 6; ++j)
    gap = std::max(gap, std::abs(p[0][j].get<double>() - p[1][j].get<double>()));
  return {gap, sigma};
}

TEST(ServoCalibration, IdentifiedJointFrictionCancelsInTheDbbCalibration) {
  // The machine's servo loads (joint ramp 2 mm) identify t0, t1 and the ramp.
  truth::Machine m = truth::Pm600Truth();
  m.joint_ramp_mm = 2.0;
  std::vector<ServoFile> servo_files;
  std::mt19937 rng(31);
  for (auto c : truth::JigPlan(720)) {
    for (bool ccw : {true, false}) {
      c.ccw = ccw;
      servo_files.push_back(ingest::ParseServoFile(
          truth::ServoText(c, truth::Simulate(m, c, 2.0, rng)), c.test_id + ".txt"));
    }
  }
  std::ifstream in("data/machines/pm600-like.json");
  std::stringstream doc;
  doc << in.rdbuf();
  const auto base = ingest::ParseHexapodMachineJson(doc.str(), "pm600-like.json");
  const IdentifyResult r = IdentifyLoads(base.geometry, *base.physics, servo_files);
  ASSERT_TRUE(r.joint_ramp.has_value());
  const auto identified =
      ingest::ParseHexapodMachineJson(usecases::MachineWithIdentified(base, r), "identified.json");
  ASSERT_EQ(identified.effects.size(), 1u);
  // DBB tests of the same machine with that joint friction (t0 8.88 N·m, ramp 2 mm).
  const auto tests = DbbTests(base, 8.88, 2.0);
  const auto [blind, blind_sigma] = DirectionGap(base, tests);
  const auto [known, known_sigma] = DirectionGap(identified, tests);
  EXPECT_GT(blind, 20.0 * blind_sigma) << "a friction-blind calibration depends on direction";
  EXPECT_LT(known, 6.0 * known_sigma) << "with the identified friction it does not";
  EXPECT_LT(known, 0.2 * blind);
}

}  // namespace
}  // namespace km::servo
