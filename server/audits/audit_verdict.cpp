#include "server/audits/audit_verdict.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <tuple>

namespace km::server {
namespace {

using nlohmann::json;

std::string Format(double v) {
  std::ostringstream o;
  o.precision(6);
  o << v;
  return o.str();
}

// The evidence's id: the job of a calibration, else the measurement.
json Evidence(const AuditValue& v, const char* prefix) {
  const std::string p(prefix);
  json j = {{p + "value", v.value}, {p + "measured_at", v.measured_at}};
  if (v.job_id) {
    j[p + "job_id"] = *v.job_id;
  } else {
    j[p + "measurement_id"] = ValueOrZero(v.measurement_id);
  }
  return j;
}

std::string EvidenceName(const AuditValue& v) {
  return v.job_id ? "calibration job " + to_string(*v.job_id)
                  : "measurement " + std::to_string(ValueOrZero(v.measurement_id));
}

std::string SetUpOf(const AuditRule& rule, const SetUpEvidence& s) {
  if (MachineWideKind(rule.kind)) return "machine";
  return SetUpName(rule.kind, s.test_id, s.direction);
}

json SetUpJson(const AuditRule& rule, const SetUpEvidence& s) {
  return {{"set_up", SetUpOf(rule, s)}, {"test_id", s.test_id}, {"direction", s.direction}};
}

// The level a compared value earns under a rule's limits and the decision rule, the limit it
// was judged against (0 at level 1) and the decision there.
struct LevelDecision {
  int level = 1;
  double limit = 0.0;
  Judgement judgement;
};

LevelDecision LevelOf(const AuditRule& rule, double value, std::optional<double> U,
                      const DecisionRule& decision_rule) {
  const bool trend = rule.change != AuditRule::Change::kNone;
  const DecisionRule used = trend ? DecisionRule{} : decision_rule;
  if (rule.stop) {
    // Within U of stop says more than beyond warn: both are level 2.
    const Judgement j = Decide(value, U, *rule.stop, used);
    if (j.decision == Decision::kBeyond) return {3, *rule.stop, j};
    if (j.decision == Decision::kUndecided) return {2, *rule.stop, j};
  }
  if (rule.warn) {
    const Judgement j = Decide(value, U, *rule.warn, used);
    if (j.decision != Decision::kWithin) return {2, *rule.warn, j};
  }
  return {};
}

std::string FindingMessage(const AuditRule& rule, const SetUpEvidence& s, double value, int level,
                           double limit, Decision decision) {
  const bool trend = rule.change != AuditRule::Change::kNone;
  const std::string where = MachineWideKind(rule.kind) ? "" : " in " + SetUpOf(rule, s);
  const std::string what = trend ? rule.kind + " " + rule.metric + where + " rose by " +
                                       Format(value) + " (from " + Format(s.reference->value) +
                                       " to " + Format(s.newest->value) + ")"
                                 : rule.kind + " " + rule.metric + where + " " + Format(value);
  const std::string U = s.newest->U ? " ± " + Format(*s.newest->U) : "";
  const std::string name = level == 3 || limit == rule.stop.value_or(-1.0) ? "stop" : "warn";
  if (decision == Decision::kUndecided) {
    return what + U + ", within its uncertainty of the " + name + " limit " + Format(limit) +
           ": undecided (" + EvidenceName(*s.newest) + ")";
  }
  return what + U + ", above the " + name + " limit " + Format(limit) + " (" +
         EvidenceName(*s.newest) + ")";
}

// Judges one set-up under a rule: its `checked` entry and, above a limit, a finding; the level.
int Judge(const AuditRule& rule, std::size_t i, const SetUpEvidence& s, json& checked,
          json& findings, const DecisionRule& decision_rule) {
  const bool trend = rule.change != AuditRule::Change::kNone;
  const double value = trend ? s.newest->value - s.reference->value : s.newest->value;
  LevelDecision d = LevelOf(rule, value, trend ? std::nullopt : s.newest->U, decision_rule);
  if (d.level == 1 && s.undecided) {
    d = {2, 0.0, Judgement{Decision::kUndecided, 0.0, false}};
  }
  const int level = d.level;
  const double limit = d.limit;
  checked["status"] = level > 1 ? "finding" : "ok";
  checked["level"] = level;
  checked.update(Evidence(*s.newest, ""));
  checked["value"] = value;
  checked["U"] = !trend && s.newest->U ? json(*s.newest->U) : json(nullptr);
  if (level > 1) checked["decision"] = ToString(d.judgement.decision);
  if (trend) {
    checked["newest_value"] = s.newest->value;
    checked.update(Evidence(*s.reference, "reference_"));
  }
  if (s.extra.is_object()) checked.update(s.extra);
  if (level == 1) return 1;
  json f = {{"rule", i}, {"kind", rule.kind}, {"metric", rule.metric}, {"level", level}};
  f.update(SetUpJson(rule, s));
  f["limit"] = limit;
  f.update(Evidence(*s.newest, ""));
  f["value"] = value;
  f["U"] = checked["U"];
  f["decision"] = ToString(d.judgement.decision);
  if (d.judgement.guard_band > 0) f["guard_band"] = d.judgement.guard_band;
  f["message"] = s.undecided && limit == 0.0
                     ? rule.kind + " conformance in " + SetUpOf(rule, s) +
                           ": figures within their uncertainty of their tolerances, undecided (" +
                           EvidenceName(*s.newest) + ")"
                     : FindingMessage(rule, s, value, level, limit, d.judgement.decision);
  if (trend) {
    f["newest_value"] = s.newest->value;
    f.update(Evidence(*s.reference, "reference_"));
  }
  if (s.extra.is_object()) f.update(s.extra);
  findings.push_back(std::move(f));
  return level;
}

// A stale set-up, once however many rules cover it: kind, test_id, direction.
using SetUpKey = std::tuple<std::string, std::string, std::string>;

struct StaleSetUps {
  std::map<SetUpKey, std::size_t> seen;  // index into `list`
  json list = json::array();
  std::vector<std::size_t> first_rule;
};

void NoteStale(const AuditRule& rule, std::size_t i, const SetUpEvidence& s, StaleSetUps& stale) {
  const SetUpKey key{rule.kind, s.test_id, s.direction};
  if (stale.seen.count(key) != 0) return;
  stale.seen[key] = stale.list.size();
  json j = {{"kind", rule.kind}};
  j.update(SetUpJson(rule, s));
  j.update(Evidence(*s.newest, ""));
  j.erase("value");
  j["age_days"] = std::floor(s.age_days * 10.0) / 10.0;
  stale.list.push_back(std::move(j));
  stale.first_rule.push_back(i);
}

// One finding of level 2 per stale set-up (the audit asked for it).
void StaleFindings(const StaleSetUps& stale, const AuditPolicy& policy, json& findings) {
  for (std::size_t k = 0; k < stale.list.size(); ++k) {
    json f = stale.list[k];
    f["rule"] = stale.first_rule[k];
    f["metric"] = "max_age_days";
    f["level"] = 2;
    f["value"] = f["age_days"];
    f["limit"] = policy.max_age_days;
    f["stale"] = true;
    f["message"] = f["kind"].get<std::string>() + " set-up " + f["set_up"].get<std::string>() +
                   " was last measured " + f["measured_at"].get<std::string>() + ", " +
                   Format(f["age_days"].get<double>()) + " days ago: older than max_age_days " +
                   std::to_string(policy.max_age_days);
    findings.push_back(std::move(f));
  }
}

// Set-ups measured with an instrument past its calibration, once however many rules cover them.
struct OverdueSetUps {
  std::map<SetUpKey, bool> seen;
  json list = json::array();
  std::vector<std::size_t> first_rule;
};

void NoteOverdue(const AuditRule& rule, std::size_t i, const SetUpEvidence& s,
                 OverdueSetUps& overdue) {
  if (!s.overdue_instrument.is_object() || !s.newest) return;
  const SetUpKey key{rule.kind, s.test_id, s.direction};
  if (!overdue.seen.emplace(key, true).second) return;
  json j = {{"kind", rule.kind}};
  j.update(SetUpJson(rule, s));
  j.update(Evidence(*s.newest, ""));
  j.erase("value");
  j.update(s.overdue_instrument);
  overdue.list.push_back(std::move(j));
  overdue.first_rule.push_back(i);
}

void OverdueFindings(const OverdueSetUps& overdue, json& findings) {
  for (std::size_t k = 0; k < overdue.list.size(); ++k) {
    json f = overdue.list[k];
    f["rule"] = overdue.first_rule[k];
    f["metric"] = "instrument_overdue";
    f["level"] = 2;
    const auto text = [&](const char* key) {
      return f.contains(key) && f[key].is_string() ? f[key].get<std::string>() : std::string("?");
    };
    f["message"] = f["kind"].get<std::string>() + " set-up " + text("set_up") +
                   " was last measured " + text("measured_at") + " with instrument " +
                   text("serial") + " past its calibration interval (due " +
                   text("calibration_due") + "): its figures rest on an uncalibrated instrument";
    findings.push_back(std::move(f));
  }
}

struct Tally {
  json findings = json::array();
  json checked = json::array();
  std::size_t ok_listed = 0, ok_not_listed = 0;
  int level = 1;
};

void Keep(json entry, Tally& t) {
  if (entry.value("status", "") == "ok") {
    if (t.ok_listed >= kMaxCheckedOk) {
      ++t.ok_not_listed;
      return;
    }
    ++t.ok_listed;
  }
  t.checked.push_back(std::move(entry));
}

json NotEvaluated(json c, const std::string& reason) {
  c["status"] = "not evaluated";
  c["reason"] = reason;
  return c;
}

void JudgeRule(const AuditRule& rule, std::size_t i, const AuditEvidence& ev, Tally& t,
               StaleSetUps& stale, OverdueSetUps& overdue, const DecisionRule& decision_rule) {
  json base = AuditRuleJson(rule);
  base["rule"] = i;
  if (ev.set_ups.empty()) {
    Keep(NotEvaluated(base, ev.missing.empty() ? "no result of this metric yet" : ev.missing), t);
    return;
  }
  const bool trend = rule.change != AuditRule::Change::kNone;
  for (const auto& s : ev.set_ups) {
    json c = base;
    c.update(SetUpJson(rule, s));
    if (s.stale && s.newest) {
      c["status"] = "stale";
      c.update(Evidence(*s.newest, ""));
      c.erase("value");
      c["age_days"] = std::floor(s.age_days * 10.0) / 10.0;
      NoteStale(rule, i, s, stale);
      Keep(std::move(c), t);
      continue;
    }
    std::string missing = s.missing;
    if (missing.empty() && !s.newest) missing = "no result of this metric yet";
    if (missing.empty() && trend && !s.reference) missing = "no reference value to compare with";
    if (!missing.empty()) {
      if (s.newest) c.update(Evidence(*s.newest, ""));
      Keep(NotEvaluated(std::move(c), missing), t);
      continue;
    }
    NoteOverdue(rule, i, s, overdue);
    t.level = std::max(t.level, Judge(rule, i, s, c, t.findings, decision_rule));
    Keep(std::move(c), t);
  }
}

}  // namespace

json EvaluateAudit(const std::vector<AuditRule>& rules, const std::vector<AuditEvidence>& evidence,
                   const AuditPolicy& policy) {
  Tally t;
  StaleSetUps stale;
  OverdueSetUps overdue;
  const AuditEvidence none;
  for (std::size_t i = 0; i < rules.size(); ++i) {
    JudgeRule(rules[i], i, i < evidence.size() ? evidence[i] : none, t, stale, overdue,
              policy.decision_rule);
  }
  if (policy.instrument_overdue_warn && !overdue.list.empty()) {
    OverdueFindings(overdue, t.findings);
    t.level = std::max(t.level, 2);
  }
  if (policy.stale_warn && !stale.list.empty()) {
    StaleFindings(stale, policy, t.findings);
    t.level = std::max(t.level, 2);
  }
  json out = {{"level", t.level},
              {"findings", std::move(t.findings)},
              {"checked", std::move(t.checked)},
              {"stale", std::move(stale.list)},
              {"max_age_days", policy.max_age_days},
              {"stale_policy", policy.stale_warn ? "warn" : "ignore"},
              {"decision_rule", DecisionRuleJson(policy.decision_rule)},
              {"instrument_overdue", std::move(overdue.list)},
              {"instrument_policy", policy.instrument_overdue_warn ? "warn" : "ignore"}};
  if (t.ok_not_listed > 0) out["checked_ok_not_listed"] = t.ok_not_listed;
  return out;
}

}  // namespace km::server
