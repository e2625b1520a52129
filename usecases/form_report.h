// JSON mapping of the form analyses (docs/formats.md §3: `form straightness`, `form flatness`,
// `form parallelism`), shared by the CLI and the server, so that
// GET /api/v1/measurements/{id}/results returns the same object as the CLI.
//
// Every object carries `reference` (the line / plane the headline figures refer to) and
// `references` (one entry per figure).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/form/flatness.h"
#include "analysis/form/parallelism.h"
#include "analysis/form/straightness.h"
#include "ingest/form_parsers.h"

namespace km::usecases {

// {straightness_lsq_um, straightness_min_zone_um, straightness_end_point_um, slope_um_per_m,
//  periodic[] {period_mm, amplitude_um, phase_deg, false_alarm_probability}, reference,
//  references{}, intercept_um, min_zone_slope_um_per_m, end_point_slope_um_per_m,
//  slope_with_periodic_um_per_m, points, length_mm}
nlohmann::json FormResultToJson(const form::StraightnessResult& r);
// {pair_id, positions_mm[], machine_um[], artefact_um[], machine_straightness_lsq_um,
//  artefact_straightness_lsq_um, machine_slope_um_per_m, artefact_slope_um_per_m,
//  reversal_setup ("artefact" | "artefact_and_sensor"), convention}
nlohmann::json FormResultToJson(const form::ReversalResult& r, const std::string& pair_id);
// {flatness_lsq_um, flatness_min_zone_um, range_um, plane{slope_x_um_per_m, slope_y_um_per_m,
//  offset_um}, min_zone_plane{...}, reference, references{}, points}
nlohmann::json FormResultToJson(const form::FlatnessResult& r);
// {parallelism_um, slope_um_per_m, length_mm, straightness_lsq_um, reference, references{},
//  points}
nlohmann::json FormResultToJson(const form::ParallelismResult& r);

// Whole-file results as the CLI prints them (with a `measurement` object holding the header).
// One straightness file: the keys at the top level. Several: {profiles[] (each with `file`),
// reversals[]}, a profile of a complete reversal pair carrying `reversal`, and a top-level
// `reversal` as well when there is exactly one pair. Throws InvalidInput naming file / line /
// field (e.g. two `reversal: a` files with the same pair_id, or the two files of a pair
// stating different `reversal_setup`s).
nlohmann::json StraightnessFilesToJson(const std::vector<ingest::StraightnessFile>& files,
                                       const form::StraightnessOptions& options = {});
nlohmann::json FlatnessFileToJson(const ingest::FlatnessFile& file);
nlohmann::json ParallelismFileToJson(const ingest::ParallelismFile& file);

}  // namespace km::usecases
