// JSON mapping of the laser-tracker self-calibration (docs/formats.md §3, `kinemetric tracker
// selfcal`). Shared by the CLI and (through the lead's wiring) the API, so both print the same
// object.
#pragma once

#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_types.h"
#include "analysis/tracker/volumetric_decomposition.h"
#include "ingest/tracker_parser.h"

namespace km::usecases {

// Contract keys: trackers_mm, points_mm, volumetric_error_um, residual_rms_um,
// position_uncertainty_um, condition_number; extras: machine_id, mode, point_ids,
// tracker_uncertainty_um, dead_paths, rejected_readings (reason "residual": readings are
// rejected only on their own evidence), spatial_outliers (points whose volumetric error stands
// out from their neighbours': point id, 0-based index, departure_um, departure_sigmas,
// largest_standardised_um, reason; a warning only, the points are kept), warnings, transform,
// sigma_um, readings_used, unknowns, iterations, decomposition (null when not given). Dropped
// points give null rows.
nlohmann::json TrackerResultToJson(const tracker::TrackerReadings& readings,
                                   const tracker::SelfCalResult& result,
                                   const tracker::GeometricDecomposition* decomposition);

// Parse (ingest/tracker_parser.h), self-calibrate, decompose and map to JSON: the whole
// `tracker selfcal --json` object for a file's bytes. Throws km::InvalidInput on bad input,
// km::NotObservable / km::DidNotConverge when the survey cannot be solved. A decomposition
// that is not observable gives "decomposition": null and "decomposition_error": reason.
// Self-calibration and decomposition of parsed readings (the decomposition is left out, with
// `decomposition_error`, when the map cannot be decomposed).
nlohmann::json AnalyzeTracker(const ingest::TrackerFile& file,
                              const tracker::SelfCalOptions& options = {},
                              const tracker::DecompositionOptions& decomposition = {});

nlohmann::json AnalyzeTrackerFile(std::string_view bytes, const std::string& file,
                                  const tracker::SelfCalOptions& options = {},
                                  const tracker::DecompositionOptions& decomposition = {});

}  // namespace km::usecases
