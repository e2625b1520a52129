// The progress of a long computation (a study, a calibration, a job), told as it goes: the
// fraction done (0…1) and the stage being worked on, e.g. "calibrating 24 parameters". One type
// for the use cases, the job runner and the pages that show it.
#pragma once

#include <functional>
#include <string>

namespace km {

using ProgressFn = std::function<void(double fraction, const std::string& stage)>;

}  // namespace km
