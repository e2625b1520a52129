// JSON mapping of the DBB analysis report, contract §3 `kinemetric dbb analyze`:
//   { "tests": [ { test_id, direction, mode, centre_offset_um [x, y], average_radial_error_um,
//                  circularity_um, min_zone_circularity_um,
//                  evaluated_over ("full_turn" | "partial_arc"), evaluated_arc_deg,
//                  iso230_4 { circular_deviation_um, radial_deviation_max_um,
//                             radial_deviation_min_um, radial_reference, evaluated_over,
//                             evaluated_arc_deg },
//                  harmonics [ { order, amplitude_um, phase_deg } ],
//                  diagnosis [ { effect, value, unit, contribution_pct, uncertainty,
//                                significance, [period_mm | width_deg, exponent,
//                                width_deg_uncertainty, spike_shape | period_deg,
//                                period_deg_uncertainty] } ],
//                  not_identifiable [ "effect (why)" ],
//                  … extra keys } ],
//     "pairs": [ { test_id, circular_hysteresis_um, bidirectional_circular_deviation_um,
//                  evaluated_over, evaluated_arc_deg } ] }
// `value` / `uncertainty` are numbers, or [x, y] arrays for centre_offset. One element of
// tests[] is what the API returns for one measurement (DbbTestToJson). For a partial arc every
// figure is over the arc (evaluated_over = "partial_arc", evaluated_arc_deg its length).
#pragma once

#include <nlohmann/json.hpp>

#include "analysis/dbb/full_analysis.h"

namespace km::dbb {

nlohmann::json DbbTestToJson(const DbbTestReport& test);
nlohmann::json DbbPairToJson(const DbbPairReport& pair);
nlohmann::json DbbReportToJson(const DbbReport& report);

}  // namespace km::dbb
