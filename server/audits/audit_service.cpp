#include "server/audits/audit_service.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <limits>
#include <map>
#include <optional>

#include "analysis/core/errors.h"
#include "ingest/identifiers.h"
#include "ingest/json_text.h"
#include "server/audits/accuracy_audit.h"
#include "server/audits/audit_gather.h"
#include "server/audits/audit_schedule.h"
#include "server/base/json_answer.h"
#include "server/jobs/jobs.h"
#include "server/measurements/analyses.h"

namespace km::server {
namespace {

using nlohmann::json;

// The audit's document as stored: {"rules": [...], "max_age_days", "stale"}; an audit stored
// before set-ups were judged holds the array of rules alone.
struct StoredAudit {
  json rules = json::array();
  AuditPolicy policy;
};

StoredAudit ReadStoredAudit(const std::string& text) {
  const json doc = ingest::ParseJsonText(text, "stored document");
  StoredAudit out;
  if (doc.is_array()) {
    out.rules = doc;
    return out;
  }
  out.rules = doc.value("rules", json::array());
  out.policy.max_age_days = doc.value("max_age_days", out.policy.max_age_days);
  out.policy.stale_warn = doc.value("stale", std::string("ignore")) == "warn";
  out.policy.decision_rule = ParseDecisionRule(doc.value("decision_rule", json()), "decision_rule");
  out.policy.instrument_overdue_warn = doc.value("instrument_overdue", std::string()) == "warn";
  return out;
}

AuditPolicy ParsePolicy(const json& body) {
  AuditPolicy p;
  if (body.contains("max_age_days") && !body["max_age_days"].is_null()) {
    const json& v = body["max_age_days"];
    if (!v.is_number_integer() || v.get<std::int64_t>() < 1 || v.get<std::int64_t>() > 3660) {
      throw InvalidInput("", 0, "max_age_days", "must be a whole number of days from 1 to 3660");
    }
    p.max_age_days = v.get<std::int64_t>();
  }
  if (body.contains("stale") && !body["stale"].is_null()) {
    const json& v = body["stale"];
    if (!v.is_string() || (v != "warn" && v != "ignore")) {
      throw InvalidInput("", 0, "stale", "must be \"warn\" or \"ignore\"");
    }
    p.stale_warn = v == "warn";
  }
  if (body.contains("instrument_overdue") && !body["instrument_overdue"].is_null()) {
    const json& v = body["instrument_overdue"];
    if (!v.is_string() || (v != "warn" && v != "ignore")) {
      throw InvalidInput("", 0, "instrument_overdue", "must be \"warn\" or \"ignore\"");
    }
    p.instrument_overdue_warn = v == "warn";
  }
  if (body.contains("decision_rule")) {
    p.decision_rule = ParseDecisionRule(body["decision_rule"], "decision_rule");
  }
  return p;
}

json ConfigJson(const AuditConfigRecord& c) {
  const auto opt = [](const std::optional<std::string>& v) { return v ? json(*v) : json(nullptr); };
  const StoredAudit stored = ReadStoredAudit(c.rules_json);
  return {{"machine_id", c.machine_id},
          {"schedule", opt(c.schedule)},
          {"rules", stored.rules},
          {"max_age_days", stored.policy.max_age_days},
          {"stale", stored.policy.stale_warn ? "warn" : "ignore"},
          {"decision_rule", DecisionRuleJson(stored.policy.decision_rule)},
          {"instrument_overdue", stored.policy.instrument_overdue_warn ? "warn" : "ignore"},
          {"updated_at", c.updated_at},
          {"last_run_at", opt(c.last_run_at)},
          {"next_run_at", opt(c.next_run_at)}};
}

AuditConfigRecord StoredConfig(AuditSource& service, const std::string& machine_id) {
  auto c = service.audit_store().GetAuditConfig(machine_id);
  if (!c) throw NotFound("machine '" + machine_id + "' has no accuracy audit");
  return *c;
}

}  // namespace

json PutAuditConfig(AuditSource& service, const std::string& machine_id, const json& body,
                    std::int64_t now) {
  if (!body.is_object()) throw InvalidInput("", 0, "", "the body must be a JSON object");
  for (const auto& [key, value] : body.items()) {
    if (key != "schedule" && key != "rules" && key != "max_age_days" && key != "stale" &&
        key != "decision_rule" && key != "instrument_overdue") {
      throw InvalidInput("", 0, key,
                         "is not a key of an audit (schedule, rules, max_age_days, stale, "
                         "decision_rule, instrument_overdue)");
    }
  }
  ingest::CheckMachineId(machine_id, "", 0);
  if (!body.contains("rules")) throw InvalidInput("", 0, "rules", "is missing");
  const auto rules = ParseAuditRules(body["rules"]);
  const AuditPolicy policy = ParsePolicy(body);
  AuditConfigRecord c;
  c.machine_id = machine_id;
  c.updated_at = IsoFromUnixSeconds(now);
  if (body.contains("schedule") && !body["schedule"].is_null()) {
    if (!body["schedule"].is_string()) {
      throw InvalidInput("", 0, "schedule", "must be a string (\"every 24h\", cron) or null");
    }
    const auto schedule = ParseAuditSchedule(body["schedule"].get<std::string>());
    c.schedule = schedule.text;
    if (const auto next = NextAuditRun(schedule, now)) c.next_run_at = IsoFromUnixSeconds(*next);
  }
  json stored = json::array();
  for (const auto& r : rules) stored.push_back(AuditRuleJson(r));
  c.rules_json = json{{"rules", stored},
                      {"max_age_days", policy.max_age_days},
                      {"stale", policy.stale_warn ? "warn" : "ignore"},
                      {"decision_rule", DecisionRuleJson(policy.decision_rule)},
                      {"instrument_overdue", policy.instrument_overdue_warn ? "warn" : "ignore"}}
                     .dump();
  if (const auto old = service.audit_store().GetAuditConfig(machine_id))
    c.last_run_at = old->last_run_at;
  service.audit_store().PutAuditConfig(c);
  return ConfigJson(c);
}

json AuditConfigJson(AuditSource& service, const std::string& machine_id) {
  return ConfigJson(StoredConfig(service, machine_id));
}

json RunAccuracyAudit(AuditSource& service, const std::string& machine_id,
                      const std::string& trigger, std::int64_t now) {
  const AuditConfigRecord config = StoredConfig(service, machine_id);
  const StoredAudit stored = ReadStoredAudit(config.rules_json);
  const auto rules = ParseAuditRules(stored.rules);
  AuditVerdictFilter last;
  last.machine_id = machine_id;
  last.limit = 1;
  const auto previous_records = service.audit_store().ListAuditVerdicts(last);
  const json previous = previous_records.empty()
                            ? json(nullptr)
                            : ingest::ParseJsonTextOrDiscarded(previous_records[0].verdict_json);
  const auto evidence =
      GatherAuditEvidence(service, machine_id, rules, stored.policy, previous, now);
  json outcome = EvaluateAudit(rules, evidence, stored.policy);
  AuditVerdictRecord v;
  v.machine_id = machine_id;
  v.trigger = trigger;
  v.created_at = IsoFromUnixSeconds(now);
  v.level = outcome["level"].get<int>();
  outcome.erase("level");
  v.verdict_json = outcome.dump();
  v.id = service.audit_store().AddAuditVerdict(v);
  return VerdictJson(v);
}

json VerdictJson(const AuditVerdictRecord& v) {
  const json body = ingest::ParseJsonTextOrDiscarded(v.verdict_json);
  json j = {{"id", v.id},
            {"machine_id", v.machine_id},
            {"level", v.level},
            {"created_at", v.created_at},
            {"trigger", v.trigger},
            {"findings", body.is_object() ? body.value("findings", json::array()) : json::array()},
            {"checked", body.is_object() ? body.value("checked", json::array()) : json::array()}};
  // Verdicts that judge set-ups also list the stale ones and the policy they were judged under.
  if (body.is_object()) {
    for (const char* key : {"stale", "max_age_days", "stale_policy", "decision_rule",
                            "instrument_overdue", "instrument_policy", "checked_ok_not_listed"}) {
      if (body.contains(key)) j[key] = body[key];
    }
  }
  j["webhook"] = v.webhook_status.empty()
                     ? json(nullptr)
                     : json{{"status", v.webhook_status}, {"attempts", v.webhook_attempts}};
  return j;
}

namespace {

// Room kept in a page for its end: "],", the page's figures and "}".
constexpr std::size_t kPageTailBytes = 256;

// Whether the storage holds a verdict at this offset (reading one at most).
bool VerdictAt(AuditSource& service, AuditVerdictFilter f, std::int64_t offset) {
  f.offset = offset;
  f.limit = 1;
  f.max_bytes = 0;
  return !service.audit_store().ListAuditVerdicts(f).empty();
}

// Writes the records into `out` one by one while they fit in max_bytes (the first always) and
// `limit` is not reached, letting go of each stored text once written; how many it wrote.
std::int64_t WriteVerdicts(std::vector<AuditVerdictRecord>& records, std::int64_t limit,
                           std::size_t max_bytes, std::string& out) {
  std::int64_t listed = 0;
  for (auto& r : records) {
    if (listed == limit) break;
    const std::string piece = AnswerText(VerdictJson(r));
    if (listed > 0 && out.size() + 1 + piece.size() + kPageTailBytes > max_bytes) break;
    if (listed > 0) out += ',';
    out += piece;
    ++listed;
    std::string().swap(r.verdict_json);
  }
  return listed;
}

std::string BuildPage(AuditSource& service, const AuditVerdictFilter& filter,
                      std::size_t max_bytes) {
  // A negative limit: no limit. One more than the limit tells whether a next page exists.
  const std::int64_t limit =
      filter.limit < 0 ? std::numeric_limits<std::int64_t>::max() - 1 : filter.limit;
  AuditVerdictFilter f = filter;
  f.limit = limit + 1;
  if (max_bytes < static_cast<std::size_t>(std::numeric_limits<std::int64_t>::max())) {
    f.max_bytes = static_cast<std::int64_t>(max_bytes);
  }
  auto records = service.audit_store().ListAuditVerdicts(f);
  std::size_t stored = 0;
  for (const auto& r : records) stored += r.verdict_json.size();
  std::string out = "{\"audits\":[";
  out.reserve(std::min(stored + records.size() * kPageTailBytes, max_bytes) + kPageTailBytes);
  const std::int64_t listed = WriteVerdicts(records, limit, max_bytes, out);
  bool more = listed < static_cast<std::int64_t>(records.size());
  if (!more && stored > max_bytes && listed < limit) {
    more = VerdictAt(service, filter, filter.offset + listed);  // the storage stopped early
  }
  const json tail = {{"limit", filter.limit},
                     {"offset", filter.offset},
                     {"truncated", more && listed < limit},
                     {"next_offset", more ? json(filter.offset + listed) : json(nullptr)}};
  out += "],";
  out += AnswerText(tail).substr(1);  // {"limit":…} without its "{"
  return out;
}

}  // namespace

std::string ListAccuracyAuditsText(AuditSource& service, const AuditVerdictFilter& filter,
                                   std::size_t max_bytes) {
  std::string page = BuildPage(service, filter, max_bytes);
#if defined(__GLIBC__)
  // Parsing the verdicts leaves many small blocks free; glibc keeps them unless asked.
  if (page.size() >= (std::size_t{1} << 20)) malloc_trim(0);
#endif
  return page;
}

json ListAccuracyAudits(AuditSource& service, const AuditVerdictFilter& filter) {
  return json::parse(
      ListAccuracyAuditsText(service, filter, std::numeric_limits<std::size_t>::max()));
}

json AccuracyAuditJson(AuditSource& service, AuditVerdictId id) {
  const auto v = service.audit_store().GetAuditVerdict(id);
  if (!v) throw NotFound("accuracy audit " + to_string(id) + " does not exist");
  return VerdictJson(*v);
}

json AuditMetricsJson() {
  json items = json::array();
  std::vector<AuditMetric> metrics = AuditMetrics();
  for (const char* kind :
       {"dbb", "straightness", "flatness", "parallelism", "positioning", "tracker", "rotary"}) {
    metrics.push_back(*FindAuditMetric(kind, kConformanceMetric));
  }
  for (const auto& m : metrics) {
    items.push_back({{"kind", m.kind},
                     {"metric", m.metric},
                     {"analysis", m.analysis.empty() ? "result" : m.analysis},
                     {"unit", m.unit},
                     {"description", m.description},
                     {"source", m.source}});
  }
  return {{"metrics", items}};
}

}  // namespace km::server
