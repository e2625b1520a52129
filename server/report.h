// JSON mapping of analysis results: the objects the CLI prints and the API serves (contract §3).
// The CLI and the server use these same functions, so a stored result equals the CLI's output.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/dbb_types.h"
#include "analysis/dbb/full_analysis.h"

namespace km::server {

inline constexpr const char* kDbbAnalysisVersion = "dbb/2";

// The whole `kinemetric dbb analyze` object for a set of files: {tests[], pairs[]}.
nlohmann::json DbbReportJson(const std::vector<dbb::DbbTest>& tests, const dbb::DbbReport& report);
nlohmann::json DbbReportJson(const std::vector<dbb::DbbTest>& tests);
// One element of `tests[]` for one file analysed on its own (what the API stores at upload).
nlohmann::json DbbTestJson(const dbb::DbbTest& test);
// Evaluated turn for plots: angle_deg[], radial_error_um[] about the least-squares circle.
nlohmann::json DbbTraceJson(const dbb::DbbTest& test, const dbb::CircularTestResult& r);

}  // namespace km::server
