// What the accuracy audits and the fleet view read, and nothing more: the storage roles they
// read and write (measurements and results, jobs, audit configurations and verdicts, tolerance
// tables, the audit log), the CW/CCW pair analysis of a stored DBB test, and the verdict on a
// stored job. The service (server/service.h) is one; the audits do not see the rest of it.
#pragma once

#include <cstdint>

#include <nlohmann/json.hpp>

#include "server/jobs/job_kinds.h"
#include "server/storage/storage.h"

namespace km::server {

class AuditSource {
 public:
  virtual ~AuditSource() = default;
  virtual MeasurementStore& measurement_store() = 0;
  virtual JobStore& job_store() = 0;
  virtual AuditStore& audit_store() = 0;
  virtual ToleranceStore& tolerance_store() = 0;
  virtual AccessStore& access_store() = 0;  // the audit log
  // The pair analysis of a stored DBB test, recomputed from its stored bytes; null when the
  // test has no partner (MeasurementService::DbbPairJson).
  virtual nlohmann::json DbbPairJson(MeasurementId id) = 0;
  // The verdict on a stored job by its kind's judge, from its result parsed already
  // (StudyService::Verdict).
  virtual JobVerdict JobVerdictOf(const JobRecord& job, const nlohmann::json& result) = 0;
};

}  // namespace km::server
