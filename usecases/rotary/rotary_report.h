// The rotary-axis location errors of an R-test file (docs/formats.md §3.18), shared by the CLI
// (`kinemetric rotary analyze`) and the service: the identification of analysis/rotary/ on the
// parsed file (ingest/rotary/rotary_parser.h) and its JSON object.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "analysis/rotary/rotary_identify.h"
#include "ingest/rotary/rotary_parser.h"

namespace km::usecases {

inline constexpr const char* kRotaryAnalysisVersion = "rotary/1";

struct RotaryReport {
  ingest::RotaryFile file;
  rotary::RotaryIdentification result;
  std::vector<std::string> warnings;
  // The `uncertainty` object (docs/formats.md §3.17): u_reading_um propagated by Monte Carlo
  // through the identification (analysis/rotary/rotary_uncertainty.h), or method "none".
  nlohmann::json uncertainty;
};

RotaryReport AnalyzeRotary(ingest::RotaryFile file);

// `<name>_um` / `<name>_urad` of a location error ("YOA_um", "BOA_urad").
std::string LocationErrorKey(rotary::Kinematics k, std::size_t index);

nlohmann::json RotaryReportToJson(const RotaryReport& report);

}  // namespace km::usecases
