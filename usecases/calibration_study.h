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

#include "analysis/core/progress.h"
#include "analysis/hexapod/calibration.h"
#include "usecases/calibration_types.h"

namespace km::usecases {

// Throws km::InvalidInput naming the test (file) when a test lacks what the method needs.
CalibrationOutcome RunCalibrationStudy(const CalibrationStudy& study,
                                       const ProgressFn& progress = {});

std::optional<hexapod::CalibrationMethod> ParseCalibrationMethod(const std::string& text,
                                                                 const std::string& field);

}  // namespace km::usecases
