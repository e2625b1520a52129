// The verdict of an accuracy audit over the evidence gathered for its rules: every set-up
// (server/audits/set_up.h) a rule applies to is judged on its own newest test, and the level is
// the worst finding. Pure: the evidence is gathered by server/audits/audit_service.cpp.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/audits/accuracy_audit.h"
#include "server/audits/decision_rule.h"
#include "server/base/ids.h"

namespace km::server {

// A value found for a rule, with its evidence: a measurement, or (kind "calibration") a job.
struct AuditValue {
  double value = 0.0;
  std::optional<MeasurementId> measurement_id;  // none when the evidence is a job
  std::string measured_at;  // measurement time, else upload time; a job's finish time
  std::optional<JobId> job_id = std::nullopt;  // the calibration job; none for a measurement
  std::optional<double> U =
      std::nullopt;  // the value's expanded uncertainty, when its result has one
};

// What was found for a rule in one set-up: the value of its newest test and, for a trend rule,
// the reference value of the same set-up. `missing` says why it cannot be judged (empty: it
// can). A stale set-up (its newest test older than the audit's max_age_days) is listed with
// that test as `newest` and its age, and not judged.
struct SetUpEvidence {
  std::string test_id, direction;  // the set-up; both empty for machine-wide kinds
  std::optional<AuditValue> newest, reference;
  std::string missing;
  bool stale = false;
  double age_days = 0.0;
  nlohmann::json overdue_instrument;  // {serial, instrument, calibration_due}: the newest test
                                      // was measured with an instrument past its calibration
  bool undecided = false;  // a conformance whose figures are within their uncertainty: level 2
  nlohmann::json extra;    // keys added to the checked entry and finding (e.g. conformance)
};

// Every set-up a rule applies to, newest first; `missing` says why there is none.
struct AuditEvidence {
  std::vector<SetUpEvidence> set_ups;
  std::string missing;
};

// How an audit treats set-ups whose newest test is old.
struct AuditPolicy {
  std::int64_t max_age_days = 365;
  bool stale_warn = false;  // a stale set-up is a level-2 finding (else listed only)
  // How an absolute rule's value and its U meet the warn and stop limits (trend rules compare
  // by the value alone): a value proven beyond stop is level 3; one proven beyond warn, or
  // within its uncertainty (guard band) of either limit, is level 2 ("decision": "undecided");
  // otherwise level 1.
  DecisionRule decision_rule;
  // A judged set-up whose newest test was measured with an instrument past its calibration
  // interval is listed in the verdict's `instrument_overdue`; with this set, each is also a
  // level-2 finding (metric "instrument_overdue").
  bool instrument_overdue_warn = false;
};

// At most this many "ok" entries are listed in `checked`; the rest are counted
// (`checked_ok_not_listed`). Findings, stale and unevaluated entries are always listed.
inline constexpr std::size_t kMaxCheckedOk = 2000;

// The verdict over rules and their evidence (same order): {"level", "findings": [{"rule",
// "kind", "metric", "set_up", "test_id", "direction", "level", "value", "limit",
// "measurement_id" (or "job_id"), "measured_at", "message", …}], "checked": [{"rule", "kind",
// "metric", …rule keys, "set_up"?, "test_id"?, "direction"?, "status": "ok" | "finding" |
// "stale" | "not evaluated", …}], "stale": [{"kind", "set_up", "test_id", "direction",
// "measurement_id" | "job_id", "measured_at", "age_days"}], "max_age_days", "stale_policy",
// "decision_rule", "instrument_overdue": [{"kind", "set_up", "test_id", "direction",
// "measurement_id", "measured_at", "serial", "instrument", "calibration_due"}],
// "instrument_policy": "ignore" | "warn"}.
// Level = the worst finding, 1 without any.
nlohmann::json EvaluateAudit(const std::vector<AuditRule>& rules,
                             const std::vector<AuditEvidence>& evidence,
                             const AuditPolicy& policy = {});

}  // namespace km::server
