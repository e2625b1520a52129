// What a hexapod calibration study is given and what it gives back (usecases/calibration_study.h
// runs it; usecases/effect_calibration.h runs it with effects).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/dbb/dbb_types.h"
#include "analysis/hexapod/calibration.h"
#include "ingest/machine_json.h"

namespace km::usecases {

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

}  // namespace km::usecases
