// Parser of `kinemetric-servo/1` servo-load files (docs/formats.md §1.7), built on the generic
// reader of ingest/text_format.h. A hexapod file carries the commanded tool-tip pose and one
// motor force per strut (columns t_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,f1..f6); a serial feed
// drive carries `# axis: X` and the columns t_s,pos_mm,force (more axes as pos_y_mm,force_y).
// Forces are in N (`force_unit: N`) or motor currents (`force_unit: current_A` with
// `force_constant_N_per_A`, one constant per strut or axis). Strict: every error is a
// km::InvalidInput (or km::TooLarge) naming file, line and field; nothing is guessed.
#pragma once

#include <string>
#include <string_view>

#include "analysis/servo/servo_types.h"
#include "ingest/text_format.h"

namespace km::ingest {

inline constexpr const char* kServoFormat = "kinemetric-servo/1";

// At least this many rows (the velocity and acceleration are finite differences).
inline constexpr std::size_t kMinServoRows = 5;

// 2 000 000 rows, lines of 4 KiB, 64 columns.
TextLimits DefaultServoLimits();

servo::ServoFile ParseServoFile(std::string_view bytes, const std::string& file,
                                const TextLimits& limits = DefaultServoLimits());

}  // namespace km::ingest
