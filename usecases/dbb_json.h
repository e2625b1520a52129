// JSON mapping of the DBB analysis report, docs/formats.md §3.1 `kinemetric dbb analyze`:
//   { "tests": [ { test_id, direction, mode, plane, deviation_units, bar_to_tool_path_factor,
//                  centre_offset_um [x, y], average_radial_error_um,
//                  circularity_um, min_zone_circularity_um,
//                  evaluated_over ("full_turn" | "partial_arc"), evaluated_arc_deg,
//                  iso230_4 { circular_deviation_um, radial_deviation_max_um,
//                             radial_deviation_min_um, radial_reference, deviation_units,
//                             evaluated_over, evaluated_arc_deg },
//                  harmonics [ { order, amplitude_um, phase_deg } ],
//                  diagnosis [ { effect, value, unit, contribution_pct, uncertainty,
//                                significance, [period_mm | width_deg, exponent,
//                                width_deg_uncertainty, width_s, width_s_uncertainty,
//                                spike_shape | period_deg, period_deg_uncertainty] } ],
//                  not_identifiable [ "effect (why)" ],
//                  … extra keys } ],
//     "pairs": [ { test_id, deviation_units, circular_hysteresis_um, circular_hysteresis_centre,
//                  circular_hysteresis_own_centres_um, circular_hysteresis_own_centres_centre,
//                  bidirectional_circular_deviation_um, bidirectional_centre,
//                  evaluated_over, evaluated_arc_deg } ] }
// Deviations are in the units deviation_units names ("tool path (in-plane)" from
// AnalyzeDbbSet): the bar deviation × bar_to_tool_path_factor (R_DBB / R; 1 for a flat test),
// as ISO 230-4 defines G, F, H and G(b) on the tool path (circular_test.h). H about the common
// least-squares centre is the ISO 230-4 figure (iso230.h); the own-centres H is a second one.
// `value` / `uncertainty` are numbers, or [x, y] arrays for centre_offset. One element of
// tests[] is what the API returns for one measurement (DbbTestToJson). For a partial arc every
// figure is over the arc (evaluated_over = "partial_arc", evaluated_arc_deg its length).
#pragma once

#include <nlohmann/json.hpp>

#include "analysis/dbb/full_analysis.h"

namespace km::usecases {

nlohmann::json DbbTestToJson(const dbb::DbbTestReport& test);
nlohmann::json DbbPairToJson(const dbb::DbbPairReport& pair);
nlohmann::json DbbReportToJson(const dbb::DbbReport& report);

}  // namespace km::usecases
