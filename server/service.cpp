#include "server/service.h"

#include "analysis/core/errors.h"
#include "ingest/dbb_parser.h"
#include "ingest/form_parsers.h"
#include "ingest/json_text.h"
#include "ingest/servo_parser.h"
#include "ingest/text_format.h"
#include "ingest/tracker_parser.h"
#include "server/base/sha256.h"
#include "server/base/time_util.h"
#include "server/jobs/jobs.h"
#include "server/measurements/analyses.h"

namespace km::server {

std::map<std::string, ingest::TextLimits> DefaultUploadLimits() {
  std::map<std::string, ingest::TextLimits> out;
  for (const auto& f : BuiltinFormats()) out[f.format] = f.limits;
  return out;
}

Service::Service(std::unique_ptr<Storage> storage, ServiceOptions options)
    : storage_(std::move(storage)),
      options_(options),
      streams_(std::make_unique<StreamHub>(*storage_, StreamOptions{})),
      acquisition_(std::make_unique<Acquisition>(
          *streams_, [this](const nlohmann::json& request,
                            const std::string& source) { return CreateStream(request, source); })),
      jobs_(std::make_unique<JobQueue>(*storage_, options.jobs)),
      audits_(std::make_unique<AuditScheduler>(*this, options.audits)) {
  jobs_->Register(kCalibrationJob, [this](const nlohmann::json& plan, const ProgressFn& p) {
    return RunCalibrationJob(plan, p);
  });
  jobs_->Register(kDiscoveryJob, [this](const nlohmann::json& plan, const ProgressFn& p) {
    return RunDiscoveryJob(plan, p);
  });
  jobs_->Start();
}

void Service::RegisterKind(const std::string& format, KindHandler handler) {
  kinds_[format] = std::move(handler);
}

std::vector<std::string> Service::Formats() const {
  std::vector<std::string> out;
  for (const auto& [k, v] : kinds_) out.push_back(k);
  return out;
}

UploadOutcome Service::Upload(std::string_view bytes, const std::string& filename) {
  const std::string file = filename.empty() ? "upload" : filename;
  if (bytes.size() > options_.max_upload_bytes) {
    throw TooLarge(file, 0, "",
                   "the upload is " + std::to_string(bytes.size()) + " bytes; the limit is " +
                       std::to_string(options_.max_upload_bytes));
  }
  // The format line is checked before it is used (a short name of plain characters).
  const std::string format = ingest::PeekFormat(bytes, file);
  const auto it = kinds_.find(format);
  if (it == kinds_.end()) {
    std::string known;
    for (const auto& [k, v] : kinds_) known += (known.empty() ? "" : ", ") + k;
    throw InvalidInput(file, 1, "format",
                       "unknown format '" + format + "'; this server accepts: " + known);
  }
  // Limits before parsing: one pass, nothing kept; TooLarge names the first line beyond them.
  ingest::TextLimits limits;
  if (const auto l = options_.upload_limits.find(format); l != options_.upload_limits.end()) {
    limits = l->second;
  }
  limits.max_bytes = options_.max_upload_bytes;
  ingest::CheckTextLimits(bytes, file, limits);
  const std::string sha = Sha256Hex(bytes);
  if (const auto existing = storage_->FindBySha256(sha)) {
    const auto rec = storage_->GetMeasurement(*existing);
    return UploadOutcome{*existing, false, sha, rec ? rec->kind : ""};
  }
  Ingested in = it->second(bytes, file);
  NewMeasurement m;
  m.sha256 = sha;
  m.kind = in.kind;
  m.format = format;
  m.machine_id = in.machine_id;
  m.test_id = in.test_id;
  m.direction = in.direction;
  if (in.measured_at) {
    m.measured_at = NormaliseIso8601(*in.measured_at);
    if (!m.measured_at) {
      throw InvalidInput(file, 0, "timestamp", "'" + *in.measured_at + "' is not ISO 8601");
    }
  }
  m.filename = filename;
  m.metadata_json = in.metadata.dump();
  m.raw.assign(bytes);
  m.samples = std::move(in.samples);
  const auto put = storage_->PutMeasurement(m, in.results);
  return UploadOutcome{put.id, put.created, sha, in.kind};
}

nlohmann::json Service::Results(std::int64_t id) {
  const auto results = storage_->GetResults(id);
  if (results.empty()) {
    // One query in the common case; the second only tells the two refusals apart.
    if (!storage_->GetMeasurement(id)) {
      throw NotFound("measurement " + std::to_string(id) + " does not exist");
    }
    throw NotFound("measurement " + std::to_string(id) + " has no stored results");
  }
  // Newest stored result of the measurement itself (results are appended as analysis versions
  // are added); the joints estimates kept with servo records are answered elsewhere.
  for (auto r = results.rbegin(); r != results.rend(); ++r) {
    if (r->analysis != kJointsAnalysis)
      return ingest::ParseJsonText(r->result_json, "stored document");
  }
  return ingest::ParseJsonText(results.back().result_json, "stored document");
}

nlohmann::json Service::MeasurementJson(const MeasurementRecord& r) const {
  nlohmann::json j;
  j["id"] = r.id;
  j["sha256"] = r.sha256;
  j["kind"] = r.kind;
  j["format"] = r.format;
  j["machine_id"] = r.machine_id;
  j["test_id"] = r.test_id;
  j["direction"] = r.direction;
  j["timestamp"] = r.measured_at ? nlohmann::json(*r.measured_at) : nlohmann::json(nullptr);
  j["uploaded_at"] = r.uploaded_at;
  j["filename"] = r.filename;
  j["sample_count"] = r.sample_count;
  return j;
}

namespace {

// The figure a list shows for a measurement of each kind (docs/formats.md §5).
struct KeyFigure {
  const char* kind;
  const char* analysis;
  const char* key;
  const char* label;
};
constexpr KeyFigure kKeyFigures[] = {
    {"dbb", "dbb", "circularity_um", "circularity"},
    {"straightness", "straightness", "straightness_min_zone_um", "straightness (minimum zone)"},
    {"parallelism", "parallelism", "parallelism_um", "parallelism"},
    {"flatness", "flatness", "flatness_min_zone_um", "flatness (minimum zone)"},
    {"tracker", "tracker", "residual_rms_um", "residual RMS"},
};

// {"name", "label", "value", "unit"} from the newest stored result, or null.
nlohmann::json KeyResultJson(const std::string& kind, const std::vector<ResultRecord>& results) {
  for (const auto& k : kKeyFigures) {
    if (kind != k.kind) continue;
    for (auto r = results.rbegin(); r != results.rend(); ++r) {
      if (r->analysis != k.analysis) continue;
      const auto j = ingest::ParseJsonTextOrDiscarded(r->result_json);
      if (!j.is_object() || !j.contains(k.key) || !j[k.key].is_number()) return nullptr;
      return {{"name", k.key}, {"label", k.label}, {"value", j[k.key]}, {"unit", "µm"}};
    }
  }
  return nullptr;
}

}  // namespace

nlohmann::json Service::ListMeasurements(const MeasurementFilter& filter) {
  const auto page = storage_->ListMeasurements(filter);
  nlohmann::json items = nlohmann::json::array();
  for (const auto& r : page.items) {
    nlohmann::json j = MeasurementJson(r);
    j["key_result"] = KeyResultJson(r.kind, storage_->GetResults(r.id));
    items.push_back(std::move(j));
  }
  return {{"items", items}, {"total", page.total}};
}

nlohmann::json Service::MeasurementWithSamples(std::int64_t id) {
  const auto rec = storage_->GetMeasurement(id);
  if (!rec) throw NotFound("measurement " + std::to_string(id) + " does not exist");
  nlohmann::json j = MeasurementJson(*rec);
  j["metadata"] = ingest::ParseJsonText(rec->metadata_json, "stored document");
  const auto block = storage_->GetSamples(id);
  nlohmann::json samples = nlohmann::json::object();
  for (std::size_t c = 0; c < block.columns.size(); ++c) {
    samples[block.columns[c]] = block.Column(c);
  }
  j["samples"] = samples;
  return j;
}

nlohmann::json Service::JobsOfMachine(const std::string& machine_id, std::int64_t limit,
                                      std::int64_t scan) {
  std::map<std::int64_t, std::string> machine_of;  // measurement id → machine, looked up once
  const auto test_machine = [&](std::int64_t id) -> const std::string& {
    auto it = machine_of.find(id);
    if (it == machine_of.end()) {
      const auto rec = storage_->GetMeasurement(id);
      it = machine_of.emplace(id, rec ? rec->machine_id : std::string()).first;
    }
    return it->second;
  };
  nlohmann::json items = nlohmann::json::array();
  for (const auto& j : storage_->ListJobs(scan)) {
    if (static_cast<std::int64_t>(items.size()) >= limit) break;
    // The request decides; only the jobs of the machine are turned into JSON (with the verdict).
    const auto req = ingest::ParseJsonTextOrDiscarded(j.request_json);
    bool mine = req.is_object() && req.value("machine_id", std::string()) == machine_id;
    if (!mine && req.is_object() && req.contains("measurement_ids") &&
        req["measurement_ids"].is_array() && !req["measurement_ids"].empty() &&
        req["measurement_ids"][0].is_number_integer()) {
      mine = test_machine(req["measurement_ids"][0].get<std::int64_t>()) == machine_id;
    }
    if (!mine) continue;
    nlohmann::json x = JobJson(j);
    x.erase("result");  // as Jobs: GET /api/v1/jobs/{id} has the result
    items.push_back(std::move(x));
  }
  return {{"items", items}};
}

std::vector<MachineSummary> Service::Machines() {
  return storage_->ListMachines();
}

bool Service::TokenKnown(const std::string& token_sha256) {
  return storage_->FindTokenRole(token_sha256).has_value();
}

std::string Service::EnsureAdminToken(const std::string& bootstrap) {
  return server::EnsureAdminToken(*storage_, bootstrap);
}

std::string EnsureAdminToken(AccessStore& storage, const std::string& bootstrap) {
  if (storage.CountTokens() > 0) return {};
  if (!bootstrap.empty()) {
    storage.PutToken(Sha256Hex(bootstrap), "admin", "bootstrap");
    return {};
  }
  const std::string token = NewRandomToken();
  storage.PutToken(Sha256Hex(token), "admin", "generated at first start");
  return token;
}

}  // namespace km::server
