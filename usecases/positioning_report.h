// The laser positioning analysis of a `kinemetric-positioning/1` file and its JSON result
// (docs/formats.md §1.8, §3.14), shared by `kinemetric positioning analyze` and the service:
// corrections (air, material), ISO 230-2 and VDI/DGQ 3441 figures, compensation table
// (docs/methods.md §15).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/positioning/air.h"
#include "analysis/positioning/compensation.h"
#include "analysis/positioning/figure_uncertainty.h"
#include "analysis/positioning/figures.h"
#include "ingest/positioning_parser.h"
#include "usecases/uncertainty_json.h"

namespace km::usecases {

inline constexpr const char* kPositioningAnalysisVersion = "positioning/1";

struct PositioningReport {
  std::string file;
  std::string machine_id;
  std::string axis;
  std::string cycle;
  std::string timestamp;
  positioning::AppliedCorrections corrections;
  std::vector<positioning::Reading> readings;  // corrected deviations, file order
  positioning::PositioningFigures figures;
  positioning::CompensationTable compensation;
  // The file's u_* keys (all six, "not stated" ones at 0) and, when it states any, the Monte
  // Carlo propagation of them through the figures (docs/methods.md §16.3).
  std::vector<UncertaintyInput> uncertainty_inputs;
  std::optional<positioning::PositioningUncertainty> uncertainty;
};

// The six input uncertainties of a positioning file as its header states them (docs/formats.md
// §1.8), in the order of positioning::PositioningInputNames().
std::vector<UncertaintyInput> PositioningUncertaintyInputs(const ingest::PositioningFile& file);

// Corrects and evaluates a parsed file; with any u_* key stated, propagates the uncertainties
// (kPositioningDraws draws, seed kPositioningSeed). Throws km::InvalidInput naming file, line
// and field.
PositioningReport AnalyzePositioning(const ingest::PositioningFile& file);

// The documented object: reversal_value_um, mean_reversal_value_um, repeatability_up_um,
// repeatability_down_um, repeatability_um, systematic_deviation_up_um,
// systematic_deviation_down_um, systematic_deviation_um, mean_deviation_range_um,
// accuracy_up_um, accuracy_down_um, accuracy_um, iso230_2_compliant, warnings[], targets{},
// air{}, material{}, compensation{}, vdi3441{}, uncertainty{} (usecases/uncertainty_json.h),
// and machine_id, axis, cycle, runs, target_count, readings, analysis_version.
nlohmann::json PositioningReportToJson(const PositioningReport& report);

// One file: the object above. Several (the same axis compared, e.g. before and after
// compensation): {files[]} in input order, each the object above with `file`.
nlohmann::json PositioningFilesToJson(const std::vector<PositioningReport>& reports);

}  // namespace km::usecases
