// One sample of a DBB test as the calibration reads it (analysis/hexapod/calibration.h): the
// commanded pose, the strut lengths the nominal model commanded for it and the bar length
// measured. Its own header, so the cost functor (calibration_cost.h) needs only this.
#pragma once

#include "analysis/hexapod/kinematics.h"

namespace km::hexapod {

struct CalibrationSample {
  Pose commanded;
  Vector6d strut_command_mm;  // IK of the nominal model
  double measured_bar_mm = 0.0;
};

}  // namespace km::hexapod
