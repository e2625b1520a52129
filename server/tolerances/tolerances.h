// Tolerances: a machine's specification of the figures its measurements must meet, e.g. ISO
// 230-4 circular deviation G ≤ 15 µm for the DBB test xy-r150, ISO 230-2 accuracy A ≤ 12 µm
// for axis X, flatness ≤ 8 µm. Separate from the limits of the accuracy audits (maintenance
// levels): a tolerance says whether a measurement conforms, not when to act.
//
// A table is a list of entries {kind, metric, tolerance, test_id?, direction?, axis?}. Kind and
// metric are those of the audit metric table (server/audits/accuracy_audit.h) read from the
// measurement's own result (analysis ""): dbb, straightness, flatness, parallelism,
// positioning, tracker, and dbb diagnosis.<effect>. A figure passes when its value (a
// magnitude) is at most the tolerance (a value equal to it is within). The scope keys narrow an
// entry to some set-ups (server/audits/set_up.h).
//
// When several entries of one metric apply to a measurement, the most specific wins: an axis or
// an exact test_id before a test_id pattern before no test_id; among those equal so far, one
// with a direction before one without; remaining ties: the smaller tolerance.
//
// This file is pure (no I/O): parsing a table and judging one result against it. Storing the
// versions of a machine's table is server/tolerances/tolerance_service.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/audits/decision_rule.h"
#include "server/audits/set_up.h"

namespace km::server {

struct ToleranceEntry {
  std::string kind;        // dbb, straightness, flatness, parallelism, positioning, tracker
  std::string metric;      // the audit metric's name; a positioning "accuracy_um.X" is stored as
                           // metric accuracy_um with axis X
  double tolerance = 0.0;  // in the metric's unit, ≥ 0
  SetUpScope scope;
};

// One version of a machine's table. version 0: the machine has no table.
struct ToleranceTable {
  std::string machine_id;
  std::int64_t version = 0;
  std::string created_at;  // ISO 8601 UTC
  std::vector<ToleranceEntry> entries;
  DecisionRule decision_rule;  // how a figure and its U are judged against its tolerance
};

inline constexpr std::size_t kMaxTolerances = 200;

// The body of PUT …/tolerances, {"tolerances": [ENTRY, …]}: at most kMaxTolerances entries (an
// empty array: no tolerances). km::InvalidInput naming the field, e.g. "tolerances[2].metric"
// (a kind or metric that takes no tolerance), "tolerances[0].tolerance" (not a finite number
// ≥ 0), "tolerances[1].axis", "tolerances[3].colour" (an unknown key), "tolerances[4]" (the
// same kind, metric and scope as an earlier entry), "tolerances", "body".
// The body may also give "decision_rule" (server/audits/decision_rule.h; absent: simple), read
// by ParseToleranceDecisionRule.
std::vector<ToleranceEntry> ParseToleranceBody(const nlohmann::json& body);
DecisionRule ParseToleranceDecisionRule(const nlohmann::json& body);

nlohmann::json ToleranceEntryJson(const ToleranceEntry& entry);
nlohmann::json ToleranceEntriesJson(const std::vector<ToleranceEntry>& entries);
// The same entries in any order, and the same rule, give the same text (the key of "same table
// again").
std::string CanonicalToleranceText(const std::vector<ToleranceEntry>& entries,
                                   const DecisionRule& rule = {});
// What is stored of a version: {"tolerances": […], "decision_rule": {…}} (a version stored
// before decision rules holds the array alone, read as the simple rule).
nlohmann::json StoredToleranceJson(const std::vector<ToleranceEntry>& entries,
                                   const DecisionRule& rule);
// {"machine_id", "version", "tolerances", "decision_rule", "created_at"}.
nlohmann::json ToleranceTableJson(const ToleranceTable& table);

// How specific a scope is (larger: more specific): 4 for an axis or an exact test_id, 2 for a
// test_id pattern, 0 for none; + 1 with a direction.
int ScopeSpecificity(const SetUpScope& scope);

// The entries of `table` that judge a measurement of this kind and set-up: one a metric, the
// most specific (ties: the smaller tolerance), in the order of the metrics' first entries.
std::vector<ToleranceEntry> ApplicableTolerances(const ToleranceTable& table,
                                                 const std::string& kind,
                                                 const std::string& test_id,
                                                 const std::string& direction);

// A measurement's conformance with `table` from its own result (docs/http.md "Tolerances and
// conformance"): {"verdict": "pass" | "fail" | "no tolerance", "tolerance_version": N | null,
// "decision_rule": {…}, "figures": [{"metric", "value", "tolerance", "unit", "U" (the figure's
// expanded uncertainty from the result's `uncertainty`, null when not known), "verdict": "pass" |
// "fail" | "undecided" | "no value", "guard_band"? (w, under a rule other than simple),
// "test_id"?, "direction"?, "axis"? (the scope of the entry that judged it)}]}. "no tolerance"
// when no entry applies; "fail" when a figure fails or the result does not hold it (a figure
// with no value is not shown to conform); else "undecided" when a figure is within its
// uncertainty (or guard band) of its tolerance; else "pass". tolerance_version is null for a
// machine without a table.
nlohmann::json Conformance(const ToleranceTable& table, const std::string& kind,
                           const std::string& test_id, const std::string& direction,
                           const nlohmann::json& result);

}  // namespace km::server
