#include "server/audits/audit_gather.h"

#include <map>
#include <optional>
#include <utility>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "server/audits/calibration_runs.h"
#include "server/base/time_util.h"
#include "server/measurements/analyses.h"
#include "server/tolerances/tolerance_service.h"
#include "server/tolerances/tolerances.h"

namespace km::server {
namespace {

using nlohmann::json;

// Pair analyses tried for one set-up (its newest tests with a partner).
constexpr int kPairTries = 2;

// A stored measurement with the results an audit reads (read when first needed), or a
// calibration job (kind "calibration").
struct Stored {
  MeasurementRecord record;
  bool loaded = false;
  json result;  // the measurement's own newest result (null when none)
  json joints;  // the newest joint-health estimate kept with it (null when none)
  std::int64_t at = 0;
  std::string time;                           // measurement (else upload) time; finish time
  std::optional<CalibrationRun> calibration;  // set for a calibration job
};

// A set-up's tests, newest first.
struct SetUpTests {
  std::string test_id, direction;
  std::vector<Stored*> tests;
};

std::vector<Stored> ListHistory(AuditSource& service, const std::string& machine_id,
                                const std::string& kind) {
  std::vector<Stored> out;
  if (kind == "calibration") {
    for (auto& run : MachineCalibrations(service, machine_id)) {
      Stored s;
      s.loaded = true;
      s.at = run.at;
      s.time = run.finished_at;
      s.calibration = std::move(run);
      out.push_back(std::move(s));
    }
    return out;
  }
  MeasurementFilter f;
  f.machine_id = machine_id;
  f.kind = kind;
  f.order = MeasurementFilter::Order::kNewest;
  f.limit = kAuditHistory;
  for (auto& rec : service.measurement_store().ListMeasurements(f).items) {
    Stored s;
    s.time = rec.measured_at ? *rec.measured_at : rec.uploaded_at;
    s.at = UnixSecondsFromIso(s.time).value_or(0);
    s.record = std::move(rec);
    out.push_back(std::move(s));
  }
  return out;
}

void LoadResults(AuditSource& service, Stored& s) {
  if (s.loaded) return;
  s.loaded = true;
  for (const auto& r : service.measurement_store().GetResults(s.record.id)) {
    json& slot = r.analysis == kJointsAnalysis ? s.joints : s.result;
    slot = ingest::ParseJsonTextOrDiscarded(r.result_json);
    if (slot.is_discarded()) slot = nullptr;
  }
}

// The metric's value in a stored test, and its expanded uncertainty when the result has one
// (written to *U when given).
std::optional<double> ValueOf(AuditSource& service, const AuditMetric& m, Stored& s,
                              std::optional<double>* U = nullptr) {
  if (s.calibration) return CalibrationMetricValue(m, *s.calibration);
  if (m.analysis == "dbb-pair") {
    try {
      const json pair = service.DbbPairJson(s.record.id);
      if (U) *U = ExtractAuditUncertainty(m, pair);
      return ExtractAuditMetric(m, pair);
    } catch (const Error&) {  // a test the pair analysis cannot take is passed over
      return std::nullopt;
    }
  }
  LoadResults(service, s);
  const json& r = m.analysis == kJointsAnalysis ? s.joints : s.result;
  if (r.is_null()) return std::nullopt;
  if (U) *U = ExtractAuditUncertainty(m, r);
  return ExtractAuditMetric(m, r);
}

AuditValue Found(double v, const Stored& s) {
  if (s.calibration) return {v, std::nullopt, s.time, s.calibration->job_id, std::nullopt};
  return {v, s.record.id, s.time, std::nullopt, std::nullopt};
}

// How far down a set-up's tests a value is looked for: machine-wide kinds take the newest that
// holds one; a pair figure the newest tests with a partner; any other the newest test only (an
// older test of the set-up is no longer its state).
std::size_t SearchDepth(const AuditRule& rule, const AuditMetric& m, std::size_t tests) {
  if (MachineWideKind(rule.kind)) return tests;
  if (m.analysis == "dbb-pair") return std::min<std::size_t>(tests, kPairTries);
  return std::min<std::size_t>(tests, 1);
}

// The machine's tests of the rule's kind grouped by set-up (machine-wide kinds: one group; a
// pair figure: by test_id), newest set-up first, within the rule's scope.
std::vector<SetUpTests> GroupSetUps(std::vector<Stored>& history, const AuditRule& rule,
                                    const AuditMetric& metric) {
  const bool machine_wide = MachineWideKind(rule.kind);
  const bool pair = metric.analysis == "dbb-pair";
  const std::string axis = AuditMetricTestId(metric);  // "accuracy_um.X": axis X only
  std::vector<SetUpTests> groups;
  std::map<std::pair<std::string, std::string>, std::size_t> index;
  for (auto& s : history) {
    const MeasurementRecord& r = s.record;
    if (!machine_wide && !axis.empty() && r.test_id != axis) continue;
    if (!machine_wide && !InScope(rule.scope, r.test_id, r.direction)) continue;
    const std::string test_id = machine_wide ? "" : r.test_id;
    const std::string direction = machine_wide || pair ? "" : r.direction;
    const auto [it, added] = index.emplace(std::make_pair(test_id, direction), groups.size());
    if (added) groups.push_back({test_id, direction, {}});
    groups[it->second].tests.push_back(&s);
  }
  return groups;
}

bool SameSetUp(const MeasurementRecord& r, const SetUpEvidence& e) {
  return r.test_id == e.test_id && (e.direction.empty() || r.direction == e.direction);
}

// The value the previous audit saw for this kind, metric and set-up (from its checked list).
std::optional<AuditValue> AtPreviousAudit(AuditSource& service, const json& previous,
                                          const AuditRule& rule, const SetUpEvidence& e) {
  if (!previous.is_object()) return std::nullopt;
  for (const auto& c : previous.value("checked", json::array())) {
    if (c.value("kind", "") != rule.kind || c.value("metric", "") != rule.metric) continue;
    const json& v = c.contains("newest_value") ? c["newest_value"] : c.value("value", json());
    const char* id_key = c.contains("job_id") ? "job_id" : "measurement_id";
    if (!v.is_number() || !c.contains(id_key) || !c[id_key].is_number_integer()) continue;
    if (c.value("status", "") == "stale") continue;
    AuditValue seen{v.get<double>(), std::nullopt, c.value("measured_at", ""), std::nullopt,
                    std::nullopt};
    if (c.contains("job_id")) {
      seen.job_id = c[id_key].get<JobId>();
    } else {
      seen.measurement_id = MeasurementId(c[id_key].get<std::int64_t>());
    }
    if (MachineWideKind(rule.kind)) return seen;
    if (c.contains("test_id")) {  // verdicts that name their set-ups
      if (c.value("test_id", "") == e.test_id && c.value("direction", "") == e.direction) {
        return seen;
      }
      continue;
    }
    const auto rec = service.measurement_store().GetMeasurement(*seen.measurement_id);
    if (rec && SameSetUp(*rec, e)) return seen;
  }
  return std::nullopt;
}

void FindReference(AuditSource& service, const AuditRule& rule, const AuditMetric& metric,
                   SetUpTests& group, const json& previous, std::int64_t now, SetUpEvidence& e) {
  if (rule.change == AuditRule::Change::kPreviousAudit) {
    e.reference = AtPreviousAudit(service, previous, rule, e);
    if (!e.reference) e.missing = "no previous audit with a value of this metric in this set-up";
    return;
  }
  const std::int64_t cutoff = now - rule.days * 86400;
  int pair_tries = kPairTries;
  for (Stored* s : group.tests) {
    if (s->at > cutoff) continue;
    if (metric.analysis == "dbb-pair" && pair_tries-- <= 0) break;
    if (const auto v = ValueOf(service, metric, *s)) {
      e.reference = Found(*v, *s);
      return;
    }
    if (metric.analysis != "dbb-pair" && !MachineWideKind(rule.kind)) break;
  }
  e.missing = (rule.kind == "calibration"
                   ? std::string("no calibration")
                   : "no result of " + SetUpName(rule.kind, e.test_id, e.direction)) +
              " at or before " + IsoFromUnixSeconds(cutoff);
}

// The set-up's newest test against the machine's tolerance table: the value is the number of
// figures that do not pass; a set-up no tolerance applies to is not evaluated.
void ConformanceOf(AuditSource& service, const ToleranceTable& table, Stored& newest,
                   SetUpEvidence& e) {
  LoadResults(service, newest);
  const json c = Conformance(table, newest.record.kind, newest.record.test_id,
                             newest.record.direction, newest.result);
  const std::string verdict = c.value("verdict", "");
  e.extra = {{"conformance", verdict}, {"tolerance_version", c.value("tolerance_version", json())}};
  if (verdict == "no tolerance") {
    e.missing = "no tolerance of the machine applies to this set-up";
    return;
  }
  double failed = 0;
  json figures = json::array(), undecided = json::array();
  for (const auto& f : c.value("figures", json::array())) {
    const std::string v = f.value("verdict", "");
    if (v == "pass") continue;
    if (v == "undecided") {
      undecided.push_back(f.value("metric", ""));
      continue;
    }
    ++failed;
    figures.push_back(f.value("metric", "") + " " + v);
  }
  e.extra["failed_figures"] = figures;
  if (!undecided.empty()) {
    e.extra["undecided_figures"] = undecided;
    e.undecided = true;
  }
  e.newest = Found(failed, newest);
}

// The instrument of a set-up's newest test when it was measured past its calibration interval
// (the result's `instrument`, docs/http.md "Instruments"): {serial, instrument, calibration_due};
// null otherwise.
json OverdueInstrument(AuditSource& service, Stored& newest) {
  LoadResults(service, newest);
  if (!newest.result.is_object() || !newest.result.contains("instrument")) return nullptr;
  const json& i = newest.result["instrument"];
  if (!i.is_object() || !i.value("overdue", false)) return nullptr;
  return {{"serial", i.value("serial", json())},
          {"instrument", i.value("instrument", json())},
          {"calibration_due", i.value("calibration_due", json())}};
}

SetUpEvidence JudgeSetUp(AuditSource& service, const AuditRule& rule, const AuditMetric& metric,
                         SetUpTests& group, const AuditPolicy& policy, const json& previous,
                         std::int64_t now, const ToleranceTable& tolerances) {
  SetUpEvidence e;
  e.test_id = group.test_id;
  e.direction = group.direction;
  const Stored& newest = *group.tests.front();
  const double age = static_cast<double>(now - newest.at) / 86400.0;
  if (newest.at > 0 && age > static_cast<double>(policy.max_age_days)) {
    e.stale = true;
    e.age_days = age;
    e.newest = Found(0.0, newest);
    return e;
  }
  if (!newest.calibration) e.overdue_instrument = OverdueInstrument(service, *group.tests.front());
  if (metric.analysis == kConformanceMetric) {
    ConformanceOf(service, tolerances, *group.tests.front(), e);  // never a trend (ParseRule)
    return e;
  }
  const std::size_t depth = SearchDepth(rule, metric, group.tests.size());
  for (std::size_t k = 0; k < depth && !e.newest; ++k) {
    std::optional<double> U;
    if (const auto v = ValueOf(service, metric, *group.tests[k], &U)) {
      e.newest = Found(*v, *group.tests[k]);
      e.newest->U = U;
    }
  }
  if (!e.newest && MachineWideKind(rule.kind)) {
    e.missing = "no result of this metric yet";
    return e;
  }
  if (!e.newest) {
    e.missing = "the newest test of this set-up (" +
                (newest.calibration ? "calibration job " + to_string(newest.calibration->job_id)
                                    : "measurement " + to_string(newest.record.id)) +
                ") holds no value of this metric";
    return e;
  }
  if (rule.change != AuditRule::Change::kNone) {
    FindReference(service, rule, metric, group, previous, now, e);
  }
  return e;
}

AuditEvidence GatherRule(AuditSource& service, const AuditRule& rule, std::vector<Stored>& history,
                         const AuditPolicy& policy, const json& previous, std::int64_t now,
                         const ToleranceTable& tolerances) {
  AuditEvidence ev;
  const auto metric = FindAuditMetric(rule.kind, rule.metric);
  if (!metric) {
    ev.missing = "unknown metric";
    return ev;
  }
  auto groups = GroupSetUps(history, rule, *metric);
  for (auto& g : groups) {
    ev.set_ups.push_back(JudgeSetUp(service, rule, *metric, g, policy, previous, now, tolerances));
  }
  if (groups.empty() && MachineWideKind(rule.kind)) {
    ev.missing = "no result of this metric yet";
  } else if (groups.empty()) {
    const std::string scope = ScopeText(rule.scope);
    ev.missing = "no " + rule.kind + " result of this machine" +
                 (scope.empty() ? std::string() : " in " + scope) + " yet";
  }
  return ev;
}

}  // namespace

std::vector<AuditEvidence> GatherAuditEvidence(AuditSource& service, const std::string& machine_id,
                                               const std::vector<AuditRule>& rules,
                                               const AuditPolicy& policy, const json& previous,
                                               std::int64_t now) {
  std::map<std::string, std::vector<Stored>> histories;
  std::vector<AuditEvidence> evidence;
  const ToleranceTable tolerances =
      ReadToleranceTable(service.tolerance_store(), machine_id).value_or(ToleranceTable{});
  for (const auto& rule : rules) {
    auto it = histories.find(rule.kind);
    if (it == histories.end()) {
      it = histories.emplace(rule.kind, ListHistory(service, machine_id, rule.kind)).first;
    }
    evidence.push_back(GatherRule(service, rule, it->second, policy, previous, now, tolerances));
  }
  return evidence;
}

}  // namespace km::server
