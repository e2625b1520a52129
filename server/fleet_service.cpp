#include "server/fleet_service.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <vector>

#include "analysis/core/errors.h"

namespace km::server {
namespace {

// A figure of a stored result: the analysis that holds it and where (a key, a key within an
// object, or the length of a vector [x, y]).
struct Metric {
  const char* metric;
  const char* label;
  const char* kind;
  const char* analysis;
  const char* key;
  const char* subkey;  // nullptr: result[key]; else result[key][subkey]
  bool norm;           // result[key] is a vector: its length
};
constexpr Metric kMetrics[] = {
    {"circularity_um", "DBB circularity", "dbb", "dbb", "circularity_um", nullptr, false},
    {"min_zone_circularity_um", "DBB circularity (minimum zone)", "dbb", "dbb",
     "min_zone_circularity_um", nullptr, false},
    {"centre_offset_um", "DBB centre offset", "dbb", "dbb", "centre_offset_um", nullptr, true},
    {"circular_deviation_um", "ISO 230-4 circular deviation G", "dbb", "dbb", "iso230_4",
     "circular_deviation_um", false},
    {"radial_deviation_max_um", "ISO 230-4 radial deviation F max", "dbb", "dbb", "iso230_4",
     "radial_deviation_max_um", false},
    {"straightness_min_zone_um", "straightness (minimum zone)", "straightness", "straightness",
     "straightness_min_zone_um", nullptr, false},
    {"flatness_min_zone_um", "flatness (minimum zone)", "flatness", "flatness",
     "flatness_min_zone_um", nullptr, false},
    {"parallelism_um", "parallelism", "parallelism", "parallelism", "parallelism_um", nullptr,
     false},
    {"residual_rms_um", "tracker residual RMS", "tracker", "tracker", "residual_rms_um", nullptr,
     false},
};

std::optional<double> ValueOf(const Metric& m, const nlohmann::json& j) {
  if (!j.is_object() || !j.contains(m.key)) return std::nullopt;
  const auto& v = m.subkey ? j[m.key].value(m.subkey, nlohmann::json()) : j[m.key];
  if (m.norm) {
    if (!v.is_array() || v.empty()) return std::nullopt;
    double ss = 0.0;
    for (const auto& x : v) {
      if (!x.is_number()) return std::nullopt;
      ss += x.get<double>() * x.get<double>();
    }
    return std::sqrt(ss);
  }
  if (!v.is_number() || !std::isfinite(v.get<double>())) return std::nullopt;
  return v.get<double>();
}

// The newest stored result of that analysis, parsed (discarded on a parse error).
std::optional<double> NewestValue(const Metric& m, const std::vector<ResultRecord>& results) {
  for (auto r = results.rbegin(); r != results.rend(); ++r) {
    if (r->analysis != m.analysis) continue;
    return ValueOf(m, nlohmann::json::parse(r->result_json, nullptr, false));
  }
  return std::nullopt;
}

void RequireMachine(Service& service, const std::string& machine_id) {
  const auto machines = service.storage().ListMachines();
  if (std::none_of(machines.begin(), machines.end(),
                   [&](const MachineSummary& m) { return m.machine_id == machine_id; })) {
    throw NotFound("machine " + machine_id + " has no measurements and no model");
  }
}

// The machine of each queued or running job (the request's machine_id, else the machine of its
// first measurement), counted.
std::map<std::string, std::int64_t> OpenJobs(Service& service) {
  std::map<std::string, std::int64_t> open;
  for (const auto& j : service.storage().ListJobs(kFleetJobScan)) {
    if (j.status != "queued" && j.status != "running") continue;
    const auto req = nlohmann::json::parse(j.request_json, nullptr, false);
    if (!req.is_object()) continue;
    std::string machine = req.value("machine_id", std::string());
    if (machine.empty() && req.contains("measurement_ids") && req["measurement_ids"].is_array() &&
        !req["measurement_ids"].empty() && req["measurement_ids"][0].is_number_integer()) {
      const auto rec =
          service.storage().GetMeasurement(req["measurement_ids"][0].get<std::int64_t>());
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
nlohmann::json NewestAudit(Service& service, const std::string& machine_id) {
  AuditVerdictFilter f;
  f.machine_id = machine_id;
  f.limit = 1;
  const auto v = service.storage().ListAuditVerdicts(f);
  if (v.empty()) return nullptr;
  return {{"id", v.front().id}, {"level", v.front().level}, {"created_at", v.front().created_at}};
}

}  // namespace

nlohmann::json TrendMetrics() {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& m : kMetrics) {
    out.push_back({{"metric", m.metric}, {"label", m.label}, {"unit", "µm"}, {"kind", m.kind}});
  }
  return out;
}

nlohmann::json Fleet(Service& service) {
  const auto open = OpenJobs(service);
  nlohmann::json machines = nlohmann::json::array();
  for (const auto& m : service.storage().ListMachines()) {
    MeasurementFilter f;
    f.machine_id = m.machine_id;
    f.order = MeasurementFilter::Order::kNewest;
    f.limit = 1;
    const auto page = service.storage().ListMeasurements(f);
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

nlohmann::json Trends(Service& service, const std::string& machine_id, const std::string& metric) {
  const auto m = std::find_if(std::begin(kMetrics), std::end(kMetrics),
                              [&](const Metric& x) { return metric == x.metric; });
  if (m == std::end(kMetrics)) {
    std::string known;
    for (const auto& x : kMetrics) known += std::string(known.empty() ? "" : ", ") + x.metric;
    throw InvalidInput("", 0, "metric", "'" + metric + "' is not a trend metric; one of " + known);
  }
  RequireMachine(service, machine_id);
  // The newest kMaxTrendPoints measurements of the kind, returned oldest first.
  MeasurementFilter f;
  f.machine_id = machine_id;
  f.kind = m->kind;
  f.order = MeasurementFilter::Order::kNewest;
  f.limit = kMaxTrendPoints;
  const auto page = service.storage().ListMeasurements(f);
  nlohmann::json points = nlohmann::json::array();
  for (auto r = page.items.rbegin(); r != page.items.rend(); ++r) {
    const auto v = NewestValue(*m, service.storage().GetResults(r->id));
    if (!v) continue;
    points.push_back({{"measured_at", r->measured_at.value_or(r->uploaded_at)},
                      {"value", *v},
                      {"measurement_id", r->id}});
  }
  return {{"machine_id", machine_id}, {"metric", m->metric}, {"label", m->label}, {"unit", "µm"},
          {"kind", m->kind},          {"points", points}};
}

}  // namespace km::server
