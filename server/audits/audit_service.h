// Accuracy audits over the stored results of a machine (server/audits/accuracy_audit.h): the stored
// rules and schedule, a run (the values found for each rule, the verdict stored), and the
// verdicts. Times are whole Unix seconds given by the caller, so that tests set the clock.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/audits/accuracy_audit.h"
#include "server/audits/audit_source.h"
#include "server/storage/storage.h"

namespace km::server {

// Validates and stores a machine's audit: body {"schedule": text | null, "rules": [...]}
// (km::InvalidInput naming the field). Answers the stored config (AuditConfigJson).
nlohmann::json PutAuditConfig(AuditSource& service, const std::string& machine_id,
                              const nlohmann::json& body, std::int64_t now);
// {"machine_id", "schedule", "rules", "updated_at", "last_run_at", "next_run_at"}; NotFound
// when the machine has no audit.
nlohmann::json AuditConfigJson(AuditSource& service, const std::string& machine_id);
// Evaluates the machine's rules over its newest results at `now` and stores the verdict
// (trigger "manual" or "schedule"); NotFound when the machine has no audit. The stored
// verdict's JSON (VerdictJson).
nlohmann::json RunAccuracyAudit(AuditSource& service, const std::string& machine_id,
                                const std::string& trigger, std::int64_t now);
// At most this many bytes of JSON in one page of verdicts (GET /api/v1/audits); a page holds
// at least one verdict, however large.
inline constexpr std::size_t kAuditPageBytes = std::size_t{4} << 20;
// One page of verdicts, newest first, as JSON text: {"audits": [VerdictJson…], "limit",
// "offset", "truncated", "next_offset"}. The filter's limit and offset choose the page; it ends
// early, before max_bytes of text, with "truncated": true. "next_offset": the offset of the
// next page, null after the last. The verdicts are read and written one by one (the storage
// reads about max_bytes of them), and memory freed by a large page goes back to the system.
std::string ListAccuracyAuditsText(AuditSource& service, const AuditVerdictFilter& filter,
                                   std::size_t max_bytes = kAuditPageBytes);
// The same page as JSON, bounded by the filter's limit only (the service's own readers, such as
// the audit report's history of verdicts).
nlohmann::json ListAccuracyAudits(AuditSource& service, const AuditVerdictFilter& filter);
// One verdict (NotFound when there is none).
nlohmann::json AccuracyAuditJson(AuditSource& service, std::int64_t id);
// {"id", "machine_id", "level", "created_at", "trigger", "findings", "checked", "webhook"}.
nlohmann::json VerdictJson(const AuditVerdictRecord& record);
// {"metrics": [{"kind", "metric", "analysis", "unit", "description", "source"}]}.
nlohmann::json AuditMetricsJson();

// At most this many of the newest jobs are looked through for a machine's calibrations.
inline constexpr std::int64_t kCalibrationJobScan = 500;

// A hexapod calibration an audit (kind "calibration") and a trend take as evidence.
struct CalibrationRun {
  std::int64_t job_id = 0;
  std::string finished_at;  // the job's updated_at
  std::int64_t at = 0;      // the same, Unix seconds
  nlohmann::json result;    // the job's result (docs/formats.md §5)
  nlohmann::json previous;  // the result of the machine's calibration before it; null for none
};

// The machine's calibrations: done hexapod_calibration jobs whose request names the machine
// (machine_id) and whose verdict is not "failed" (server/jobs/jobs.h), newest first by when they
// finished, among the newest kCalibrationJobScan jobs.
std::vector<CalibrationRun> MachineCalibrations(AuditSource& service,
                                                const std::string& machine_id);
// A metric of kind "calibration" at one calibration; nullopt when it does not hold it (the
// change metric: also the oldest calibration, which has none before it).
std::optional<double> CalibrationMetricValue(const AuditMetric& metric, const CalibrationRun& run);

}  // namespace km::server
