// Parser of laser-tracker multilateration files, `# format: kinemetric-tracker/1` (contract
// §1.2; [Tracker paper] eq. 1): header `machine_id`, `trackers` (n ≥ 4), `mode` (`simultaneous` or
// `sequential`), any number of `tracker_guess_mm: j, x, y, z` lines (machine frame); columns
// `point,x_mm,y_mm,z_mm,d1_um,…,dn_um`; `# beam_break: tracker, point[, at_point|elsewhere]`
// lines among the data rows say the tracker was re-zeroed from that point on: at that point
// (default; its reading there is 0) or at a place that is not a surveyed point (an unknown dead
// path). Validation is strict: every error names the file, the line and the field.
#pragma once

#include <map>
#include <string>
#include <string_view>

#include "analysis/tracker/tracker_types.h"
#include "ingest/text_format.h"

namespace km::ingest {

inline constexpr const char* kTrackerFormat = "kinemetric-tracker/1";

struct TrackerFile {
  tracker::TrackerReadings readings;
  std::map<std::string, std::string> metadata;  // every header key (unknown ones too)
};

// What one survey file may hold at most (ingest/text_format.h): 200 000 points, 128 columns,
// 10 000 beam breaks, lines of 4 KiB. The self-calibration costs far more than the parse (about
// 0.15 ms a point with 4 trackers, growing with the square of the number of trackers): the
// server refuses uploads beyond its own, much lower, limits (ServiceOptions::upload_limits).
TextLimits DefaultTrackerLimits();

// Throws km::InvalidInput (or km::TooLarge) naming file, line and field.
TrackerFile ParseTrackerFile(std::string_view bytes, const std::string& file,
                             const TextLimits& limits = DefaultTrackerLimits());

// Writes readings in the same format (readings with 0.1 nm, positions with 1 nm resolution);
// missing (non-finite) readings cannot be written and are refused with InvalidInput.
std::string WriteTrackerFile(const tracker::TrackerReadings& readings);

}  // namespace km::ingest
