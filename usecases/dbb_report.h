// JSON mapping of analysis results: the objects the CLI prints and the API serves (docs/formats.md
// §3). The CLI and the server use these same functions, so a stored result equals the CLI's output.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/dbb_types.h"
#include "analysis/dbb/full_analysis.h"

namespace km::usecases {

// dbb/3: deviations of cone tests in tool-path units (deviation_units, bar_to_tool_path_factor);
// pairs also give H about each trace's own centre and name the centre of each figure.
inline constexpr const char* kDbbAnalysisVersion = "dbb/3";

// The whole `kinemetric dbb analyze` object for a set of files: {tests[], pairs[]}.
nlohmann::json DbbReportJson(const std::vector<dbb::DbbTest>& tests, const dbb::DbbReport& report);
nlohmann::json DbbReportJson(const std::vector<dbb::DbbTest>& tests);
// One element of `tests[]` for one file analysed on its own (what the API stores at upload).
nlohmann::json DbbTestJson(const dbb::DbbTest& test);
// Evaluated turn for plots: angle_deg[], radial_error_um[] about the least-squares circle, in
// the units of `r` (deviation_units; the service passes tool-path results, as the report).
nlohmann::json DbbTraceJson(const dbb::DbbTest& test, const dbb::CircularTestResult& r);

}  // namespace km::usecases
