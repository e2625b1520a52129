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
#include "server/audits/calibration_runs.h"
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
nlohmann::json AccuracyAuditJson(AuditSource& service, AuditVerdictId id);
// {"id", "machine_id", "level", "created_at", "trigger", "findings", "checked", "webhook"}.
nlohmann::json VerdictJson(const AuditVerdictRecord& record);
// {"metrics": [{"kind", "metric", "analysis", "unit", "description", "source"}]}.
nlohmann::json AuditMetricsJson();

}  // namespace km::server
