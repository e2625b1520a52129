// Accuracy audits: per machine, rules over the newest results of each kind of measurement (and
// of the machine's hexapod calibrations, kind "calibration"), evaluated into a verdict of level 1
// (normal), 2 (warn: still compensable) or 3 (stop). Not to be confused with the audit log of
// state-changing requests (server/access/access.h).
//
// This file holds the pure parts: the table of metrics an audit can read from stored results
// (the same table validates rules, answers GET /api/v1/audit-metrics and is documented in
// docs/http.md), the rules, and the evaluation of rules over the values found. Gathering the
// values from storage is server/audits/audit_service.cpp.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/audits/set_up.h"

namespace km::server {

// One metric: where it is read and what it means. Every metric is "bigger is worse" (a
// magnitude: a signed figure is taken as its absolute value).
struct AuditMetric {
  std::string kind;  // measurement kind: dbb, straightness, flatness, parallelism, tracker, servo;
                     // "calibration": the machine's done hexapod_calibration jobs
  std::string metric;    // the name rules use
  std::string analysis;  // the result read: "" the measurement's own result; "servo-joints" the
                         // joint-health estimate kept with servo records; "dbb-pair" the CW/CCW
                         // pair analysis of a DBB test with its partner; "hexapod_calibration"
                         // a calibration job's result; "hexapod_calibration-pair" the object
                         // {"newest": result, "previous": the calibration before's result}
  std::string unit;
  std::string description;
  std::string source;  // JSON pointer or rule of the value in that result, for the docs
};

// The test a metric reads: the axis of a positioning metric of one axis ("accuracy_um.X" → "X",
// only measurements with that test_id); empty: the newest measurement of the kind, whatever its
// test.
std::string AuditMetricTestId(const AuditMetric& metric);

// Every metric with a fixed name, in the order documented. DBB diagnosis values are named
// "diagnosis.<effect>" (docs/formats.md §4, e.g. "diagnosis.backlash_x"), listed here once as
// "diagnosis.<effect>". A positioning metric of one axis is named "<metric>.<axis>" (e.g.
// "accuracy_um.X": the newest positioning test of axis X).
const std::vector<AuditMetric>& AuditMetrics();
// The metric of a kind and name (diagnosis.<effect> included); nullopt when there is none.
std::optional<AuditMetric> FindAuditMetric(const std::string& kind, const std::string& metric);
// The metric's value in a result of its analysis; nullopt when the result does not hold it.
std::optional<double> ExtractAuditMetric(const AuditMetric& metric, const nlohmann::json& result);
// The expanded uncertainty U of the metric's figure in the same result, when the result carries
// it: /uncertainty/figures/<figure>/U_um (a pair metric: /pair/uncertainty/…), <figure> the
// metric's name without an axis ("accuracy_um.X" → accuracy_um; docs/formats.md §3.17).
std::optional<double> ExtractAuditUncertainty(const AuditMetric& metric,
                                              const nlohmann::json& result);

// The metric "conformance" of the measurement kinds that take tolerances: the number of figures
// of a set-up's newest test that do not meet the machine's tolerance table
// (server/tolerances/tolerances.h). A rule of it may give "level": 2 or 3 (default 3) instead of
// limits: a set-up that fails its tolerances is a finding of that level.
inline constexpr const char* kConformanceMetric = "conformance";

// Kinds judged machine-wide (one set-up: the machine): the joint-health estimates kept with servo
// records and the hexapod calibrations. Every other kind is judged per set-up.
bool MachineWideKind(const std::string& kind);

// A rule: a finding of level 2 when the compared value exceeds warn, 3 when it exceeds stop.
// It applies to every set-up of its kind within its scope (server/audits/set_up.h). Absolute
// rules compare the newest value of each set-up; trend rules compare its increase over the value
// at the previous audit (kPreviousAudit) or over the set-up's newest result at or before
// now − days (kDays).
struct AuditRule {
  std::string kind, metric;
  SetUpScope scope;
  std::optional<double> warn, stop;
  enum class Change { kNone, kPreviousAudit, kDays } change = Change::kNone;
  std::int64_t days = 0;
};

inline constexpr std::size_t kMaxAuditRules = 200;

// The rules of a request body's "rules" array; km::InvalidInput naming "rules[i].field".
std::vector<AuditRule> ParseAuditRules(const nlohmann::json& rules);
nlohmann::json AuditRuleJson(const AuditRule& rule);

}  // namespace km::server
