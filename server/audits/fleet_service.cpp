#include "server/audits/fleet_service.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "server/audits/accuracy_audit.h"
#include "server/audits/audit_service.h"
#include "server/audits/set_up.h"
#include "server/measurements/analyses.h"

namespace km::server {
namespace {

// At most this many pair analyses a trend of a pair figure (each analyses two DBB files).
constexpr std::size_t kMaxPairPoints = 100;

// The audit metric of that name (docs/http.md; diagnosis.<effect> of DBB tests included).
std::optional<AuditMetric> MetricNamed(const std::string& name) {
  for (const auto& m : AuditMetrics()) {
    if (m.metric == name && m.metric.find('<') == std::string::npos) return m;
  }
  if (auto m = FindAuditMetric("positioning", name)) return m;  // "<metric>.<axis>"
  return FindAuditMetric("dbb", name);
}

// The metric's value for one measurement: from its own newest result, the newest joints
// estimate kept with it, or the analysis of its CW/CCW pair (none without a partner).
std::optional<double> ValueAt(AuditSource& service, const AuditMetric& m, MeasurementId id,
                              const std::vector<ResultRecord>& results) {
  if (m.analysis == "dbb-pair") {
    try {
      return ExtractAuditMetric(m, service.DbbPairJson(id));
    } catch (const NotFound&) {
      return std::nullopt;  // no opposite-direction partner stored
    } catch (const InvalidInput&) {
      return std::nullopt;  // a partner the pair analysis refuses
    }
  }
  const bool joints = m.analysis == kJointsAnalysis;
  for (auto r = results.rbegin(); r != results.rend(); ++r) {
    if ((r->analysis == kJointsAnalysis) != joints) continue;
    const auto j = ingest::ParseJsonTextOrDiscarded(r->result_json);
    return j.is_discarded() ? std::nullopt : ExtractAuditMetric(m, j);
  }
  return std::nullopt;
}

void RequireMachine(AuditSource& service, const std::string& machine_id) {
  const auto machines = service.measurement_store().ListMachines();
  if (std::none_of(machines.begin(), machines.end(),
                   [&](const MachineSummary& m) { return m.machine_id == machine_id; })) {
    throw NotFound("machine " + machine_id + " has no measurements and no model");
  }
}

// The machine of each queued or running job (the request's machine_id, else the machine of its
// first measurement), counted.
std::map<std::string, std::int64_t> OpenJobs(AuditSource& service) {
  std::map<std::string, std::int64_t> open;
  for (const auto& j : service.job_store().ListJobs(kFleetJobScan)) {
    if (j.status != JobStatus::kQueued && j.status != JobStatus::kRunning) continue;
    const auto req = ingest::ParseJsonTextOrDiscarded(j.request_json);
    if (!req.is_object()) continue;
    std::string machine = req.value("machine_id", std::string());
    if (machine.empty() && req.contains("measurement_ids") && req["measurement_ids"].is_array() &&
        !req["measurement_ids"].empty() && req["measurement_ids"][0].is_number_integer()) {
      const auto rec = service.measurement_store().GetMeasurement(
          req["measurement_ids"][0].get<MeasurementId>());
      if (rec) machine = rec->machine_id;
    }
    if (!machine.empty()) ++open[machine];
  }
  return open;
}

nlohmann::json OrNull(const std::optional<std::string>& s) {
  return s ? nlohmann::json(*s) : nlohmann::json(nullptr);
}

// The newest accuracy audit of the machine {id, level, created_at}, or null.
nlohmann::json NewestAudit(AuditSource& service, const std::string& machine_id) {
  AuditVerdictFilter f;
  f.machine_id = machine_id;
  f.limit = 1;
  const auto v = service.audit_store().ListAuditVerdicts(f);
  if (v.empty()) return nullptr;
  return {{"id", v.front().id}, {"level", v.front().level}, {"created_at", v.front().created_at}};
}

// A calibration metric at each of the machine's calibrations, oldest first, each point with its
// job (kind "calibration": no measurement).
nlohmann::json CalibrationPoints(AuditSource& service, const AuditMetric& m,
                                 const std::string& machine_id) {
  const auto runs = MachineCalibrations(service, machine_id);
  nlohmann::json points = nlohmann::json::array();
  for (auto r = runs.rbegin(); r != runs.rend(); ++r) {
    const auto v = CalibrationMetricValue(m, *r);
    if (!v || !std::isfinite(*v)) continue;
    points.push_back({{"measured_at", r->finished_at}, {"value", *v}, {"job_id", r->job_id}});
  }
  return points;
}

}  // namespace

std::map<std::string, std::size_t> AuditRuleCounts(AuditSource& service) {
  std::map<std::string, std::size_t> out;
  for (const auto& c : service.audit_store().ListAuditConfigs()) {
    const auto doc = ingest::ParseJsonText(c.rules_json, "stored document");
    const auto& rules = doc.is_object() ? doc.value("rules", nlohmann::json::array()) : doc;
    out[c.machine_id] = rules.is_array() ? rules.size() : 0;
  }
  return out;
}

nlohmann::json TrendMetrics() {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& m : AuditMetrics()) {
    if (m.metric.find('<') != std::string::npos) continue;  // diagnosis.<effect>: by name
    out.push_back(
        {{"metric", m.metric}, {"label", m.description}, {"unit", m.unit}, {"kind", m.kind}});
  }
  return out;
}

nlohmann::json Fleet(AuditSource& service) {
  const auto open = OpenJobs(service);
  nlohmann::json machines = nlohmann::json::array();
  for (const auto& m : service.measurement_store().ListMachines()) {
    MeasurementFilter f;
    f.machine_id = m.machine_id;
    f.order = MeasurementFilter::Order::kNewest;
    f.limit = 1;
    const auto page = service.measurement_store().ListMeasurements(f);
    nlohmann::json last = nullptr;
    if (!page.items.empty()) {
      const auto& r = page.items.front();
      last = {{"id", r.id},
              {"kind", r.kind},
              {"test_id", r.test_id},
              {"measured_at", OrNull(r.measured_at)},
              {"uploaded_at", r.uploaded_at}};
    }
    const auto it = open.find(m.machine_id);
    machines.push_back({{"machine_id", m.machine_id},
                        {"measurements", m.measurement_count},
                        {"model_versions", m.model_versions},
                        {"last_measurement", last},
                        {"open_jobs", it == open.end() ? 0 : it->second},
                        {"audit", NewestAudit(service, m.machine_id)}});
  }
  return {{"machines", machines}};
}

nlohmann::json Trends(AuditSource& service, const std::string& machine_id,
                      const std::string& metric) {
  const auto m = MetricNamed(metric);
  if (!m) {
    throw InvalidInput("", 0, "metric",
                       "'" + metric +
                           "' is not a trend metric; GET /api/v1/audit-metrics lists them (and "
                           "diagnosis.<effect> for DBB tests, <metric>.<axis> for positioning)");
  }
  RequireMachine(service, machine_id);
  const auto answer = [&](nlohmann::json points) {
    return nlohmann::json{{"machine_id", machine_id}, {"metric", metric}, {"label", m->description},
                          {"unit", m->unit},          {"kind", m->kind},  {"points", points}};
  };
  if (m->kind == "calibration") return answer(CalibrationPoints(service, *m, machine_id));
  // The newest measurements of the kind (fewer for a pair figure), returned oldest first.
  MeasurementFilter f;
  f.machine_id = machine_id;
  f.kind = m->kind;
  if (const auto axis = AuditMetricTestId(*m); !axis.empty()) f.test_id = axis;  // one axis
  f.order = MeasurementFilter::Order::kNewest;
  f.limit = m->analysis == "dbb-pair" ? static_cast<std::int64_t>(kMaxPairPoints) : kMaxTrendPoints;
  const auto page = service.measurement_store().ListMeasurements(f);
  nlohmann::json points = nlohmann::json::array();
  for (auto r = page.items.rbegin(); r != page.items.rend(); ++r) {
    const auto v = ValueAt(service, *m, r->id, service.measurement_store().GetResults(r->id));
    if (!v || !std::isfinite(*v)) continue;
    // The test and direction let a client draw one series a test (a circle of one plane,
    // radius and direction; one axis of a laser run) instead of joining them all.
    points.push_back(
        {{"measured_at", r->measured_at.value_or(r->uploaded_at)},
         {"value", *v},
         {"measurement_id", r->id},
         {"test_id", r->test_id},
         {"direction", r->direction},
         {"set_up", m->analysis == "dbb-pair" ? SetUpName(m->kind, r->test_id, "")
                                              : SetUpName(m->kind, r->test_id, r->direction)}});
  }
  return answer(std::move(points));
}

}  // namespace km::server
