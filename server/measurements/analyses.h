// Names of stored analyses that are not a format's own result (storage.h NewResult::analysis).
#pragma once

namespace km::server {

// The analysis name of a stored joints estimate: each estimate is kept as a result of every
// servo measurement it used, with "measurement_ids" and "machine_version" added; its
// analysis_version is "servo/1 #" and the first 16 hex digits of the SHA-256 of the JSON, so
// the same estimate asked for again is stored once. GET …/results never answers it (it
// answers the measurement's own result).
inline constexpr const char* kJointsAnalysis = "servo-joints";

}  // namespace km::server
