// The fleet overview and the trends of a machine's figures over time, read from what is stored
// (docs/formats.md §5): for each machine its newest measurement, how many it has, its open jobs
// and its newest accuracy audit; for one machine and metric, the metric of each stored result,
// oldest first.
#pragma once

#include <cstddef>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "server/audits/audit_source.h"

namespace km::server {

// At most this many jobs are looked at for the open-job counts (the newest).
inline constexpr std::int64_t kFleetJobScan = 2000;
// At most this many points a trend (the newest of them; 100 for a figure of a DBB pair).
inline constexpr std::int64_t kMaxTrendPoints = 5000;

// {"machines": [{"machine_id", "measurements", "model_versions", "last_measurement": {"id",
// "kind", "test_id", "measured_at", "uploaded_at"} | null, "open_jobs", "audit": {"id",
// "level", "created_at"} | null}]} by machine_id; audit is the newest accuracy audit.
nlohmann::json Fleet(AuditSource& service);

// {"machine_id", "metric", "label", "unit", "kind", "points": [{"measured_at", "value",
// "measurement_id", "test_id", "direction", "set_up"}]} (set_up: the name of the point's set-up,
// server/audits/set_up.h: one series a set-up), oldest first (measurement time, else upload time):
// the metric as an accuracy audit reads it (server/audits/accuracy_audit.h: the same table and
// extraction, so a trend and an audit's limits agree), for each measurement of its kind. A metric
// of kind "calibration": for each of the machine's calibrations (MachineCalibrations), points
// {"measured_at" (when the job finished), "value", "job_id"}. Another metric is
// InvalidInput naming the field "metric"; a machine with neither measurements nor a model
// NotFound.
nlohmann::json Trends(AuditSource& service, const std::string& machine_id,
                      const std::string& metric);

// The number of rules of each machine that has an accuracy audit (GET /api/v1/machines answers
// it with each machine, so a client knows whether to ask for the rules).
std::map<std::string, std::size_t> AuditRuleCounts(AuditSource& service);

// The metrics a trend can show: [{"metric", "label", "unit", "kind"}] (those of the
// audits but diagnosis.<effect>, which is asked for by name).
nlohmann::json TrendMetrics();

}  // namespace km::server
