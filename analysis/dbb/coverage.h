// Which part of the circle the samples of a DBB test cover, and whether that is enough — ONE
// rule for every test, shared by the parser (ingest/dbb_parser.cpp) and the analysis
// (circular_test.h):
//
//   the largest gap between neighbouring samples, the closing gap included, is at most the
//   allowed gap kMaxGapDeg (10°).
//
// The samples are in time order; their progress along the direction of motion must increase
// strictly. What the test is:
//  * a FULL TURN when the file declares arc_deg = 360, or declares nothing and the samples come
//    back to within the allowed gap of their start (span ≥ 360° − kMaxGapDeg). The closing gap
//    is 360° − span (the way from the last sample back to the first; none when the samples go
//    past 360°). Uneven sampling is fine: a 0.1°/9° trace ending 9° before its start is a full
//    turn.
//  * a PARTIAL ARC otherwise: of the declared arc_deg (kMinArcDeg ≤ arc_deg < 360), or of the
//    samples' own span when nothing is declared. When the samples fall short of a declared arc,
//    the missing part is a gap at the end of the arc and counts like any other gap. An arc
//    must be at least kMinArcDeg (180°) long: on a shorter arc the centre, the radius and the
//    minimum zone are not determined well enough to evaluate. Ballbar systems run such arcs
//    (typically 220°) in vertical planes, where a full circle would hit the table.
// (The former 16-sample minimum is gone: the gap rule already needs ≥ 36 samples for a turn and
// ≥ 19 for a 180° arc.)
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "analysis/dbb/dbb_types.h"

namespace km::dbb {

inline constexpr double kMaxGapDeg = 10.0;   // the allowed gap between neighbouring samples
inline constexpr double kMinArcDeg = 180.0;  // shortest partial arc that is evaluated

struct Coverage {
  bool ok = false;
  bool full_turn = false;
  bool arc_declared = false;
  double arc_deg = 0.0;          // length of the evaluated arc: 360 for a full turn
  double span_deg = 0.0;         // progress from the first to the last sample
  double largest_gap_deg = 0.0;  // closing / end gap included
  bool largest_is_closing = false;
  std::size_t largest_gap_sample = 0;  // sample after the largest gap (between samples)
  // When !ok: why (a sentence for the field angle_deg) and the sample it points at.
  std::string reason;
  std::string field = "angle_deg";  // "arc_deg" when the declared arc itself is refused
  std::size_t reason_sample = 0;
};

// Applies the rule above to angles in degrees (time order) of a test running in `direction`,
// with the arc the file declares (if any). Never throws.
Coverage CheckCoverage(const std::vector<double>& angle_deg, Direction direction,
                       std::optional<double> declared_arc_deg);

}  // namespace km::dbb
