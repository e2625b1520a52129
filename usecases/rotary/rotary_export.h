// `kinemetric rotary export FILE --format linuxcnc|csv` (docs/formats.md §3.18): the identified
// location errors of an R-test as corrected pivot parameters of LinuxCNC's table-rotary-tilting
// kinematics (analysis/rotary/rotary_pivots.h, docs/methods.md §17.7), with the direction errors
// that no pivot parameter can correct listed as "adjust mechanically".
#pragma once

#include <string>

#include "analysis/rotary/rotary_pivots.h"
#include "usecases/rotary/rotary_report.h"

namespace km::usecases {

rotary::PivotCorrection RotaryPivots(const RotaryReport& report);

// "linuxcnc": HAL `setp` lines (comments start with #) followed by a plain table as comments;
// "csv": parameter,nominal_mm,delta_mm,corrected_mm then error,value,sigma,action rows.
// Throws InvalidInput for another format.
std::string ExportRotary(const RotaryReport& report, const std::string& format);

}  // namespace km::usecases
