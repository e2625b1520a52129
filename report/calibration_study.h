// Hexapod calibration study ([PM-600 report] ch. 2, §5.2): calibrate the 24 kinematic parameters
// from a set of DBB tests, predict every trace after calibration (eq. 5.2), optionally run the
// test-set reduction study (§5.2.3), and map it all to the JSON of docs/formats.md §3
// `kinemetric hexapod calibrate`. Shared by the CLI and the server's background jobs.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/dbb/dbb_types.h"
#include "analysis/hexapod/calibration.h"
#include "ingest/machine_json.h"

namespace km::server {

struct CalibrationStudy {
  ingest::MachineDefinition machine;
  std::vector<dbb::DbbTest> tests;
  std::vector<std::string> names;  // file names or measurement ids, for messages and output
  // Default: absolute when every test carries fixed_ball_mm, else centre-corrected.
  std::optional<hexapod::CalibrationMethod> method;
  int max_samples_per_test = 0;  // 0: all samples
  int reduction_min_tests = 0;   // > 0: run the reduction study down to this many tests
  // Effects fitted together with the kinematics (docs/hexapod-effects.md), e.g.
  // {"gravity_deflection", "joint_friction"}; empty: the plain 24-parameter calibration.
  std::vector<std::string> effects;
};

struct CalibrationOutcome {
  nlohmann::json report;                 // docs/formats.md §3 keys and more
  ingest::MachineDefinition calibrated;  // machine with the calibrated geometry
};

// Progress callback: fraction 0…1 and the stage being worked on.
using ProgressFn = std::function<void(double, const std::string&)>;

// Throws km::InvalidInput naming the test (file) when a test lacks what the method needs.
CalibrationOutcome RunCalibrationStudy(const CalibrationStudy& study,
                                       const ProgressFn& progress = {});

std::optional<hexapod::CalibrationMethod> ParseCalibrationMethod(const std::string& text,
                                                                 const std::string& field);

}  // namespace km::server
