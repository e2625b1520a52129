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
#include "server/audits/audit_schedule.h"
#include "server/jobs/jobs.h"
#include "server/measurements/analyses.h"

namespace km::server {
namespace {

using nlohmann::json;

// How many of a machine's newest measurements of a kind an audit looks through, and how many
// CW/CCW pair analyses it computes for one rule at most.
constexpr std::int64_t kHistory = 500;
constexpr int kMaxPairAnalyses = 4;
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

std::string TimeOf(const MeasurementRecord& r) {
  return r.measured_at ? *r.measured_at : r.uploaded_at;
}

// The machine's newest measurements of a kind, newest first, without their results.
std::vector<Stored> ListHistory(AuditSource& service, const std::string& machine_id,
                                const std::string& kind) {
  MeasurementFilter f;
  f.machine_id = machine_id;
  f.kind = kind;
  f.order = MeasurementFilter::Order::kNewest;
  f.limit = kHistory;
  std::vector<Stored> out;
  for (auto& rec : service.storage().ListMeasurements(f).items) {
    Stored s;
    s.time = TimeOf(rec);
    s.at = UnixSecondsFromIso(s.time).value_or(0);
    s.record = std::move(rec);
    out.push_back(std::move(s));
  }
  return out;
}

std::vector<Stored> ListCalibrationHistory(AuditSource& service, const std::string& machine_id) {
  std::vector<Stored> out;
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

void LoadResults(AuditSource& service, Stored& s) {
  if (s.loaded) return;
  s.loaded = true;
  for (const auto& r : service.storage().GetResults(s.record.id)) {
    json& slot = r.analysis == kJointsAnalysis ? s.joints : s.result;
    slot = ingest::ParseJsonTextOrDiscarded(r.result_json);
    if (slot.is_discarded()) slot = nullptr;
  }
}

std::optional<double> ValueOf(AuditSource& service, const AuditMetric& m, Stored& s,
                              int& pair_budget) {
  if (s.calibration) return CalibrationMetricValue(m, *s.calibration);
  if (m.analysis == "dbb-pair") {
    if (pair_budget <= 0) return std::nullopt;
    --pair_budget;
    try {
      return ExtractAuditMetric(m, service.DbbPairJson(s.record.id));
    } catch (const Error&) {  // a test the pair analysis cannot take is passed over
      return std::nullopt;
    }
  }
  LoadResults(service, s);
  const json& r = m.analysis == kJointsAnalysis ? s.joints : s.result;
  return r.is_null() ? std::nullopt : ExtractAuditMetric(m, r);
}

AuditValue Found(double v, const Stored& s) {
  if (s.calibration) return {v, 0, s.time, s.calibration->job_id};
  return {v, s.record.id, s.time};
}

// The value of the rule's metric at the previous audit (from that verdict's checked list), with
// the measurement or (kind "calibration") the job it was read from.
std::optional<AuditValue> AtPreviousAudit(const json& previous, const AuditRule& rule) {
  if (!previous.is_object()) return std::nullopt;
  for (const auto& c : previous.value("checked", json::array())) {
    if (c.value("kind", "") != rule.kind || c.value("metric", "") != rule.metric) continue;
    const json& v = c.contains("newest_value") ? c["newest_value"] : c.value("value", json());
    const char* id_key = c.contains("job_id") ? "job_id" : "measurement_id";
    if (!v.is_number() || !c.contains(id_key) || !c[id_key].is_number_integer()) continue;
    AuditValue seen{v.get<double>(), 0, c.value("measured_at", ""), 0};
    (c.contains("job_id") ? seen.job_id : seen.measurement_id) = c[id_key].get<std::int64_t>();
    return seen;
  }
  return std::nullopt;
}

bool SameTest(const MeasurementRecord& a, const MeasurementRecord& b) {
  return a.test_id == b.test_id && a.direction == b.direction;
}

std::string TestName(const MeasurementRecord& r) {
  std::string name = r.test_id.empty() ? "(no test_id)" : r.test_id;
  return r.direction.empty() ? name : name + " " + r.direction;
}

// A trend's reference is a value of the same test (test_id and direction) as the newest one:
// the value the previous audit saw, or the newest at or before now − days.
void FindReference(AuditSource& service, const AuditMetric& metric, const AuditRule& rule,
                   std::vector<Stored>& history, const Stored& newest, const json& previous,
                   std::int64_t now, AuditEvidence& ev) {
  if (rule.change == AuditRule::Change::kPreviousAudit) {
    ev.reference = AtPreviousAudit(previous, rule);
    if (!ev.reference) {
      ev.missing = "no previous audit with a value of this metric";
      return;
    }
    if (newest.calibration) return;  // calibrations of a machine are all compared
    const auto seen = service.storage().GetMeasurement(ev.reference->measurement_id);
    if (!seen || !SameTest(*seen, newest.record)) {
      ev.missing = "the previous audit saw another test than " + TestName(newest.record) +
                   " (measurement " + std::to_string(ev.reference->measurement_id) + ")";
      ev.reference.reset();
    }
    return;
  }
  const std::int64_t cutoff = now - rule.days * 86400;
  int budget = kMaxPairAnalyses;
  for (auto& s : history) {
    if (s.at > cutoff || !SameTest(s.record, newest.record)) continue;
    if (const auto v = ValueOf(service, metric, s, budget)) {
      ev.reference = Found(*v, s);
      return;
    }
  }
  ev.missing = (newest.calibration ? std::string("no calibration")
                                   : "no result of test " + TestName(newest.record)) +
               " at or before " + IsoFromUnixSeconds(cutoff);
}

AuditEvidence Gather(AuditSource& service, const AuditRule& rule, std::vector<Stored>& history,
                     const json& previous, std::int64_t now) {
  AuditEvidence ev;
  const auto metric = FindAuditMetric(rule.kind, rule.metric);
  if (!metric) {
    ev.missing = "unknown metric";
    return ev;
  }
  const std::string test_id = AuditMetricTestId(*metric);
  int budget = kMaxPairAnalyses;
  for (auto& s : history) {
    if (!test_id.empty() && s.record.test_id != test_id) continue;
    if (const auto v = ValueOf(service, *metric, s, budget)) {
      ev.newest = Found(*v, s);
      if (rule.change != AuditRule::Change::kNone) {
        FindReference(service, *metric, rule, history, s, previous, now, ev);
      }
      break;
    }
  }
  return ev;
}

json ConfigJson(const AuditConfigRecord& c) {
  const auto opt = [](const std::optional<std::string>& v) { return v ? json(*v) : json(nullptr); };
  return {{"machine_id", c.machine_id},
          {"schedule", opt(c.schedule)},
          {"rules", ingest::ParseJsonText(c.rules_json, "stored document")},
          {"updated_at", c.updated_at},
          {"last_run_at", opt(c.last_run_at)},
          {"next_run_at", opt(c.next_run_at)}};
}

AuditConfigRecord StoredConfig(AuditSource& service, const std::string& machine_id) {
  auto c = service.storage().GetAuditConfig(machine_id);
  if (!c) throw NotFound("machine '" + machine_id + "' has no accuracy audit");
  return *c;
}

}  // namespace

json PutAuditConfig(AuditSource& service, const std::string& machine_id, const json& body,
                    std::int64_t now) {
  if (!body.is_object()) throw InvalidInput("", 0, "", "the body must be a JSON object");
  for (const auto& [key, value] : body.items()) {
    if (key != "schedule" && key != "rules") {
      throw InvalidInput("", 0, key, "is not a key of an audit (schedule, rules)");
    }
  }
  ingest::CheckMachineId(machine_id, "", 0);
  if (!body.contains("rules")) throw InvalidInput("", 0, "rules", "is missing");
  const auto rules = ParseAuditRules(body["rules"]);
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
  c.rules_json = stored.dump();
  if (const auto old = service.storage().GetAuditConfig(machine_id))
    c.last_run_at = old->last_run_at;
  service.storage().PutAuditConfig(c);
  return ConfigJson(c);
}

json AuditConfigJson(AuditSource& service, const std::string& machine_id) {
  return ConfigJson(StoredConfig(service, machine_id));
}

json RunAccuracyAudit(AuditSource& service, const std::string& machine_id,
                      const std::string& trigger, std::int64_t now) {
  const AuditConfigRecord config = StoredConfig(service, machine_id);
  const auto rules = ParseAuditRules(ingest::ParseJsonText(config.rules_json, "stored document"));
  AuditVerdictFilter last;
  last.machine_id = machine_id;
  last.limit = 1;
  const auto previous_records = service.storage().ListAuditVerdicts(last);
  const json previous = previous_records.empty()
                            ? json(nullptr)
                            : ingest::ParseJsonTextOrDiscarded(previous_records[0].verdict_json);
  std::map<std::string, std::vector<Stored>> histories;
  std::vector<AuditEvidence> evidence;
  for (const auto& rule : rules) {
    auto it = histories.find(rule.kind);
    if (it == histories.end()) {
      it = histories
               .emplace(rule.kind, rule.kind == "calibration"
                                       ? ListCalibrationHistory(service, machine_id)
                                       : ListHistory(service, machine_id, rule.kind))
               .first;
    }
    evidence.push_back(Gather(service, rule, it->second, previous, now));
  }
  const json outcome = EvaluateAudit(rules, evidence);
  AuditVerdictRecord v;
  v.machine_id = machine_id;
  v.level = outcome["level"].get<int>();
  v.trigger = trigger;
  v.created_at = IsoFromUnixSeconds(now);
  v.verdict_json = json{{"findings", outcome["findings"]}, {"checked", outcome["checked"]}}.dump();
  v.id = service.storage().AddAuditVerdict(v);
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
  j["webhook"] = v.webhook_status.empty()
                     ? json(nullptr)
                     : json{{"status", v.webhook_status}, {"attempts", v.webhook_attempts}};
  return j;
}

namespace {

// Answers hold text from clients and old rows: invalid UTF-8 is replaced (U+FFFD), as in every
// JSON answer of the API.
std::string DumpText(const json& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

// Room kept in a page for its end: "],", the page's figures and "}".
constexpr std::size_t kPageTailBytes = 256;

// Whether the storage holds a verdict at this offset (reading one at most).
bool VerdictAt(AuditSource& service, AuditVerdictFilter f, std::int64_t offset) {
  f.offset = offset;
  f.limit = 1;
  f.max_bytes = 0;
  return !service.storage().ListAuditVerdicts(f).empty();
}

// Writes the records into `out` one by one while they fit in max_bytes (the first always) and
// `limit` is not reached, letting go of each stored text once written; how many it wrote.
std::int64_t WriteVerdicts(std::vector<AuditVerdictRecord>& records, std::int64_t limit,
                           std::size_t max_bytes, std::string& out) {
  std::int64_t listed = 0;
  for (auto& r : records) {
    if (listed == limit) break;
    const std::string piece = DumpText(VerdictJson(r));
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
  auto records = service.storage().ListAuditVerdicts(f);
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
  out += DumpText(tail).substr(1);  // {"limit":…} without its "{"
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

json AccuracyAuditJson(AuditSource& service, std::int64_t id) {
  const auto v = service.storage().GetAuditVerdict(id);
  if (!v) throw NotFound("accuracy audit " + std::to_string(id) + " does not exist");
  return VerdictJson(*v);
}

json AuditMetricsJson() {
  json items = json::array();
  for (const auto& m : AuditMetrics()) {
    items.push_back({{"kind", m.kind},
                     {"metric", m.metric},
                     {"analysis", m.analysis.empty() ? "result" : m.analysis},
                     {"unit", m.unit},
                     {"description", m.description},
                     {"source", m.source}});
  }
  return {{"metrics", items}};
}

std::vector<CalibrationRun> MachineCalibrations(AuditSource& service,
                                                const std::string& machine_id) {
  std::vector<CalibrationRun> runs;
  for (const auto& j : service.storage().ListJobs(kCalibrationJobScan)) {
    if (j.kind != kCalibrationJob || j.status != JobStatus::kDone) continue;
    const json request = ingest::ParseJsonTextOrDiscarded(j.request_json);
    if (!request.is_object() || !request.contains("machine_id") ||
        request["machine_id"] != machine_id) {
      continue;
    }
    json result = ingest::ParseJsonTextOrDiscarded(j.result_json);
    if (!result.is_object() || JudgeJob(j.kind, j.status, result, j.error).verdict == "failed") {
      continue;
    }
    CalibrationRun run;
    run.job_id = j.id;
    run.finished_at = j.updated_at;
    run.at = UnixSecondsFromIso(j.updated_at).value_or(0);
    run.result = std::move(result);
    runs.push_back(std::move(run));
  }
  // Newest first by when they finished (jobs are listed by when they were queued).
  std::stable_sort(runs.begin(), runs.end(), [](const CalibrationRun& a, const CalibrationRun& b) {
    return a.at != b.at ? a.at > b.at : a.job_id > b.job_id;
  });
  for (std::size_t i = 0; i + 1 < runs.size(); ++i) runs[i].previous = runs[i + 1].result;
  return runs;
}

std::optional<double> CalibrationMetricValue(const AuditMetric& metric, const CalibrationRun& run) {
  if (metric.analysis == "hexapod_calibration-pair") {
    if (run.previous.is_null()) return std::nullopt;
    return ExtractAuditMetric(metric, json{{"newest", run.result}, {"previous", run.previous}});
  }
  return ExtractAuditMetric(metric, run.result);
}

}  // namespace km::server
