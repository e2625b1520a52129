// THE list of serial-machine DBB error effects. One line per effect drives the registry
// (ids, names, parameter counts, evaluation). Adding an effect = one new header in models/
// + one line here. The order is also the priority order when two effects cannot be told
// apart from the available data (the earlier one is kept).
#pragma once

#include "analysis/serial_effects/models/backlash.h"
#include "analysis/serial_effects/models/centre_offset.h"
#include "analysis/serial_effects/models/cyclic_error.h"
#include "analysis/serial_effects/models/lateral_play.h"
#include "analysis/serial_effects/models/radius_error.h"
#include "analysis/serial_effects/models/reversal_spike.h"
#include "analysis/serial_effects/models/scale_mismatch.h"
#include "analysis/serial_effects/models/servo_lag.h"
#include "analysis/serial_effects/models/servo_mismatch.h"
#include "analysis/serial_effects/models/squareness.h"
#include "analysis/serial_effects/models/stick_slip.h"
#include "analysis/serial_effects/models/straightness.h"

// X(id, model type)
#define KM_SERIAL_EFFECT_LIST(X)       \
  X(kCentreOffset, CentreOffset)       \
  X(kRadiusError, RadiusError)         \
  X(kServoLag, ServoLag)               \
  X(kSquareness, Squareness)           \
  X(kScaleMismatch, ScaleMismatch)     \
  X(kServoMismatch, ServoMismatch)     \
  X(kBacklashU, Backlash<0>)           \
  X(kBacklashV, Backlash<1>)           \
  X(kReversalSpikeU, ReversalSpike<0>) \
  X(kReversalSpikeV, ReversalSpike<1>) \
  X(kLateralPlayU, LateralPlay<0>)     \
  X(kLateralPlayV, LateralPlay<1>)     \
  X(kStraightnessU, Straightness<0>)   \
  X(kStraightnessV, Straightness<1>)   \
  X(kCyclicErrorU, CyclicError<0>)     \
  X(kCyclicErrorV, CyclicError<1>)     \
  X(kStickSlip, StickSlip)
