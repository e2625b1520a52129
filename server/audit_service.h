// Accuracy audits over the stored results of a machine (server/accuracy_audit.h): the stored
// rules and schedule, a run (the values found for each rule, the verdict stored), and the
// verdicts. Times are whole Unix seconds given by the caller, so that tests set the clock.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "server/storage.h"

namespace km::server {

class Service;

// Validates and stores a machine's audit: body {"schedule": text | null, "rules": [...]}
// (km::InvalidInput naming the field). Answers the stored config (AuditConfigJson).
nlohmann::json PutAuditConfig(Service& service, const std::string& machine_id,
                              const nlohmann::json& body, std::int64_t now);
// {"machine_id", "schedule", "rules", "updated_at", "last_run_at", "next_run_at"}; NotFound
// when the machine has no audit.
nlohmann::json AuditConfigJson(Service& service, const std::string& machine_id);
// Evaluates the machine's rules over its newest results at `now` and stores the verdict
// (trigger "manual" or "schedule"); NotFound when the machine has no audit. The stored
// verdict's JSON (VerdictJson).
nlohmann::json RunAccuracyAudit(Service& service, const std::string& machine_id,
                                const std::string& trigger, std::int64_t now);
// {"audits": [VerdictJson…]} newest first; one verdict (NotFound when there is none).
nlohmann::json ListAccuracyAudits(Service& service, const AuditVerdictFilter& filter);
nlohmann::json AccuracyAuditJson(Service& service, std::int64_t id);
// {"id", "machine_id", "level", "created_at", "trigger", "findings", "checked", "webhook"}.
nlohmann::json VerdictJson(const AuditVerdictRecord& record);
// {"metrics": [{"kind", "metric", "analysis", "unit", "description", "source"}]}.
nlohmann::json AuditMetricsJson();

}  // namespace km::server
