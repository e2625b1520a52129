#include "server/tolerances/tolerances.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "analysis/core/errors.h"
#include "server/audits/accuracy_audit.h"

namespace km::server {
namespace {

using nlohmann::json;

std::string EntryField(std::size_t i, const std::string& key) {
  return "tolerances[" + std::to_string(i) + "]" + (key.empty() ? "" : "." + key);
}

[[noreturn]] void RefuseEntry(std::size_t i, const std::string& key, const std::string& why) {
  throw InvalidInput("", 0, EntryField(i, key), why);
}

bool KnownKey(const std::string& key) {
  static const char* const kKeys[] = {"kind",    "metric",    "tolerance",
                                      "test_id", "direction", "axis"};
  return std::any_of(std::begin(kKeys), std::end(kKeys), [&](const char* k) { return key == k; });
}

std::string TextKey(const json& e, std::size_t i, const char* key) {
  if (!e.contains(key)) RefuseEntry(i, key, "is required");
  if (!e[key].is_string() || e[key].get<std::string>().empty()) {
    RefuseEntry(i, key, "must be a non-empty string");
  }
  return e[key].get<std::string>();
}

// The audit metric of the entry, taken only when it is read from the measurement's own result.
AuditMetric EntryMetric(const std::string& kind, const std::string& metric, std::size_t i) {
  const auto m = FindAuditMetric(kind, metric);
  if (m && m->analysis.empty()) return *m;
  bool kind_known = false;
  for (const auto& a : AuditMetrics())
    kind_known = kind_known || (a.kind == kind && a.analysis.empty());
  if (!kind_known) {
    RefuseEntry(i, "kind",
                "'" + kind +
                    "' takes no tolerances (dbb, straightness, flatness, parallelism, "
                    "positioning, tracker, rotary)");
  }
  RefuseEntry(i, "metric",
              "'" + metric + "' is not a figure of a " + kind +
                  " measurement's own result (GET /api/v1/audit-metrics, analysis \"\")");
}

double ToleranceValue(const json& e, std::size_t i) {
  if (!e.contains("tolerance")) RefuseEntry(i, "tolerance", "is required");
  const json& t = e["tolerance"];
  if (!t.is_number() || !std::isfinite(t.get<double>())) {
    RefuseEntry(i, "tolerance", "must be a finite number");
  }
  if (t.get<double>() < 0) RefuseEntry(i, "tolerance", "must be ≥ 0 (figures are magnitudes)");
  return t.get<double>();
}

ToleranceEntry ParseEntry(const json& e, std::size_t i) {
  if (!e.is_object()) RefuseEntry(i, "", "must be an object {kind, metric, tolerance, …}");
  for (const auto& [key, value] : e.items()) {
    if (!KnownKey(key)) {
      RefuseEntry(i, key,
                  "is not a key of a tolerance (kind, metric, tolerance, test_id, "
                  "direction, axis)");
    }
  }
  ToleranceEntry out;
  out.kind = TextKey(e, i, "kind");
  out.metric = TextKey(e, i, "metric");
  const AuditMetric metric = EntryMetric(out.kind, out.metric, i);
  out.scope = ParseSetUpScope(e, out.kind, EntryField(i, ""));
  if (const std::string axis = AuditMetricTestId(metric); !axis.empty()) {
    if (out.scope.axis && *out.scope.axis != axis) {
      RefuseEntry(i, "axis", "names axis " + *out.scope.axis + " but the metric names " + axis);
    }
    out.scope.axis = axis;
    out.metric = out.metric.substr(0, out.metric.find('.'));
  }
  out.tolerance = ToleranceValue(e, i);
  return out;
}

// The entry's kind, metric and scope as one text: two entries with the same one are the same
// specification twice.
std::string EntryKey(const ToleranceEntry& e) {
  json j = ToleranceEntryJson(e);
  j.erase("tolerance");
  return j.dump();
}

}  // namespace

std::vector<ToleranceEntry> ParseToleranceBody(const json& body) {
  if (!body.is_object())
    throw InvalidInput("", 0, "body", "must be an object {\"tolerances\": […]}");
  for (const auto& [key, value] : body.items()) {
    if (key != "tolerances" && key != "decision_rule") {
      throw InvalidInput("", 0, key,
                         "is not a key of a tolerance table (tolerances, decision_rule)");
    }
  }
  if (!body.contains("tolerances") || !body["tolerances"].is_array()) {
    throw InvalidInput("", 0, "tolerances", "must be an array of tolerances (may be empty)");
  }
  const json& list = body["tolerances"];
  if (list.size() > kMaxTolerances) {
    throw InvalidInput("", 0, "tolerances",
                       "holds " + std::to_string(list.size()) + " entries; at most " +
                           std::to_string(kMaxTolerances));
  }
  std::vector<ToleranceEntry> out;
  std::map<std::string, std::size_t> seen;
  for (std::size_t i = 0; i < list.size(); ++i) {
    out.push_back(ParseEntry(list[i], i));
    const auto [at, inserted] = seen.emplace(EntryKey(out.back()), i);
    if (!inserted) {
      RefuseEntry(
          i, "",
          "has the same kind, metric and scope as tolerances[" + std::to_string(at->second) + "]");
    }
  }
  return out;
}

json ToleranceEntryJson(const ToleranceEntry& entry) {
  json j = {{"kind", entry.kind}, {"metric", entry.metric}, {"tolerance", entry.tolerance}};
  AddScopeJson(entry.scope, j);
  return j;
}

json ToleranceEntriesJson(const std::vector<ToleranceEntry>& entries) {
  json out = json::array();
  for (const auto& e : entries) out.push_back(ToleranceEntryJson(e));
  return out;
}

DecisionRule ParseToleranceDecisionRule(const json& body) {
  if (!body.is_object() || !body.contains("decision_rule")) return {};
  return ParseDecisionRule(body["decision_rule"], "decision_rule");
}

std::string CanonicalToleranceText(const std::vector<ToleranceEntry>& entries,
                                   const DecisionRule& rule) {
  std::vector<std::string> texts;
  for (const auto& e : entries) texts.push_back(ToleranceEntryJson(e).dump());
  std::sort(texts.begin(), texts.end());
  // A simple rule adds nothing: a table stored before decision rules keeps its text.
  if (rule.kind != DecisionRule::Kind::kSimple) texts.push_back(DecisionRuleJson(rule).dump());
  return json(texts).dump();
}

json StoredToleranceJson(const std::vector<ToleranceEntry>& entries, const DecisionRule& rule) {
  return {{"tolerances", ToleranceEntriesJson(entries)}, {"decision_rule", DecisionRuleJson(rule)}};
}

json ToleranceTableJson(const ToleranceTable& table) {
  return {{"machine_id", table.machine_id},
          {"version", table.version},
          {"tolerances", ToleranceEntriesJson(table.entries)},
          {"decision_rule", DecisionRuleJson(table.decision_rule)},
          {"created_at", table.created_at}};
}

int ScopeSpecificity(const SetUpScope& scope) {
  int rank = 0;
  if (scope.axis || (scope.test_id && scope.test_id->find('*') == std::string::npos)) {
    rank = 4;
  } else if (scope.test_id) {
    rank = 2;
  }
  return rank + (scope.direction ? 1 : 0);
}

std::vector<ToleranceEntry> ApplicableTolerances(const ToleranceTable& table,
                                                 const std::string& kind,
                                                 const std::string& test_id,
                                                 const std::string& direction) {
  std::vector<ToleranceEntry> chosen;  // one a metric, in the order of first appearance
  for (const auto& e : table.entries) {
    if (e.kind != kind || !InScope(e.scope, test_id, direction)) continue;
    auto it = std::find_if(chosen.begin(), chosen.end(),
                           [&](const ToleranceEntry& c) { return c.metric == e.metric; });
    if (it == chosen.end()) {
      chosen.push_back(e);
      continue;
    }
    const int have = ScopeSpecificity(it->scope), mine = ScopeSpecificity(e.scope);
    if (mine > have || (mine == have && e.tolerance < it->tolerance)) *it = e;
  }
  return chosen;
}

namespace {

// The unit of a figure: the metric's, or for a diagnosed effect the one its result states.
std::string FigureUnit(const AuditMetric& m, const json& result) {
  if (m.metric.rfind("diagnosis.", 0) != 0) return m.unit;
  const std::string effect = m.metric.substr(10);
  if (result.is_object() && result.contains("diagnosis") && result["diagnosis"].is_array()) {
    for (const auto& d : result["diagnosis"]) {
      if (d.is_object() && d.value("effect", "") == effect && d.contains("unit") &&
          d["unit"].is_string()) {
        return d["unit"].get<std::string>();
      }
    }
  }
  return "";
}

const char* VerdictOf(Decision d) {
  return d == Decision::kWithin ? "pass" : d == Decision::kBeyond ? "fail" : "undecided";
}

json Figure(const ToleranceEntry& e, const json& result, const DecisionRule& rule) {
  const auto metric = FindAuditMetric(e.kind, e.metric);
  json f = {{"metric", e.metric},
            {"value", nullptr},
            {"tolerance", e.tolerance},
            {"unit", metric ? FigureUnit(*metric, result) : ""},
            {"U", nullptr},
            {"verdict", "no value"}};
  const auto value =
      metric && result.is_object() ? ExtractAuditMetric(*metric, result) : std::optional<double>();
  if (value.has_value() && std::isfinite(*value)) {
    const auto U = ExtractAuditUncertainty(*metric, result);
    const Judgement j = Decide(*value, U, e.tolerance, rule);
    f["value"] = *value;
    if (j.u_known) f["U"] = *U;
    f["verdict"] = VerdictOf(j.decision);
    if (rule.kind != DecisionRule::Kind::kSimple) {
      f["guard_band"] = j.guard_band;
      if (!j.u_known) f["note"] = "U not known (no input uncertainty stated): the value alone";
    }
  }
  AddScopeJson(e.scope, f);
  return f;
}

}  // namespace

json Conformance(const ToleranceTable& table, const std::string& kind, const std::string& test_id,
                 const std::string& direction, const json& result) {
  json figures = json::array();
  bool any_fail = false, any_undecided = false;
  for (const auto& e : ApplicableTolerances(table, kind, test_id, direction)) {
    figures.push_back(Figure(e, result, table.decision_rule));
    const std::string v = figures.back()["verdict"].get<std::string>();
    any_fail = any_fail || v == "fail" || v == "no value";
    any_undecided = any_undecided || v == "undecided";
  }
  const char* verdict = figures.empty() ? "no tolerance"
                        : any_fail      ? "fail"
                        : any_undecided ? "undecided"
                                        : "pass";
  return {{"verdict", verdict},
          {"tolerance_version", table.version > 0 ? json(table.version) : json(nullptr)},
          {"decision_rule", DecisionRuleJson(table.decision_rule)},
          {"figures", std::move(figures)}};
}

}  // namespace km::server
