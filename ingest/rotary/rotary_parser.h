// Parser of the R-test file of a trunnion table's rotary axes `# format: kinemetric-rotary/1`
// (docs/formats.md §1.10), built on the generic reader of ingest/text_format.h.
//
// Header: machine_id, test_id, kinematics (AC-trunnion | BC-trunnion), the nominal tilt-axis line
// (a_axis_mm: y, z for AC; b_axis_mm: x, z for BC), c_axis_mm: x, y, sphere_mm: x, y, z; optional
// timestamp (ISO 8601), u_reading_um (0 … 100 µm) and the instrument keys of every format
// (§1.9). Columns a_deg (AC) or b_deg (BC), c_deg, dx_um, dy_um, dz_um and optionally time_s, no
// other. The first pose is at zero angles; at least 4 poses. Every error is a km::InvalidInput
// naming file, line and field.
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/rotary/rotary_types.h"
#include "ingest/text_format.h"

namespace km::ingest {

inline constexpr std::string_view kRotaryFormat = "kinemetric-rotary/1";

struct RotaryFile {
  std::string file;  // name used in messages
  std::string machine_id;
  std::string test_id;
  std::string timestamp;  // empty when the file has none
  std::map<std::string, std::string> metadata;
  std::optional<double> u_reading_um;
  rotary::RotaryTest test;
  std::vector<double> time_s;      // empty without the time_s column
  std::vector<std::size_t> lines;  // the line of each pose
};

// 20 000 poses (an R-test takes tens to a few thousand; the uncertainty of 20 000 takes about
// 0.7 s), lines of 4 KiB, 16 columns.
TextLimits DefaultRotaryLimits();

RotaryFile ParseRotaryFile(std::string_view bytes, const std::string& file,
                           const TextLimits& limits = DefaultRotaryLimits());

}  // namespace km::ingest
