// Results are computed from uploaded numbers; numbers so large that the analysis overflows
// would come out as non-finite values (written as null). Such a result is refused as bad input
// rather than stored.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace km::server {

// Throws km::InvalidInput naming `file` and, as the field, the path of the first non-finite
// number in `result` (e.g. "tests[0].centre_offset_um[1]"): the values are too large to analyse.
void RequireFiniteResult(const nlohmann::json& result, const std::string& file);

}  // namespace km::server
