// The stored measurements: uploads, results, lists and the queries recomputed from a stored file.
#include "server/measurements/measurement_service.h"

#include <cmath>
#include <cstdlib>

#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/full_analysis.h"
#include "ingest/file_formats.h"
#include "ingest/form_parsers.h"
#include "ingest/iso8601.h"
#include "ingest/json_text.h"
#include "ingest/positioning_parser.h"
#include "ingest/text_format.h"
#include "render/dbb_plot.h"
#include "server/base/json_answer.h"
#include "server/base/sha256.h"
#include "server/base/time_util.h"
#include "server/measurements/analyses.h"
#include "server/measurements/kinds.h"
#include "usecases/dbb_json.h"
#include "usecases/dbb_report.h"
#include "usecases/form_report.h"
#include "usecases/positioning_export.h"
#include "usecases/positioning_report.h"

namespace km::server {

MeasurementService::MeasurementService(MeasurementStore& store, UploadOptions options)
    : store_(store), options_(std::move(options)) {}

std::map<std::string, ingest::TextLimits> DefaultUploadLimits() {
  std::map<std::string, ingest::TextLimits> out;
  for (const auto& f : BuiltinFormats()) out[f.format] = f.limits;
  return out;
}

void MeasurementService::RegisterKind(const std::string& format, KindHandler handler) {
  kinds_[format] = std::move(handler);
}

std::vector<std::string> MeasurementService::Formats() const {
  std::vector<std::string> out;
  for (const auto& [k, v] : kinds_) out.push_back(k);
  return out;
}

UploadOutcome MeasurementService::Upload(std::string_view bytes, const std::string& filename) {
  const std::string file = filename.empty() ? "upload" : filename;
  if (bytes.size() > options_.max_upload_bytes) {
    throw TooLarge(file, 0, "",
                   "the upload is " + std::to_string(bytes.size()) + " bytes; the limit is " +
                       std::to_string(options_.max_upload_bytes));
  }
  // The format, recognised from the bytes (ingest/file_formats.h): the same bytes are always
  // read again the same way, so the stored format names how they were read.
  const ingest::FileFormat& recognised = ingest::RecogniseFormat(bytes, file);
  const std::string format(recognised.name);
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
  recognised.check_limits(bytes, file, limits);
  const std::string sha = Sha256Hex(bytes);
  if (const auto existing = store_.FindBySha256(sha)) {
    const auto rec = store_.GetMeasurement(*existing);
    UploadOutcome out{*existing, false, sha, rec ? rec->kind : ""};
    if (rec && judges_) out.conformance = Judge(judges_(), *rec, store_.GetResults(*existing));
    return out;
  }
  Ingested in = it->second(bytes, file, instruments_);
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
  const auto put = store_.PutMeasurement(m, in.results);
  UploadOutcome out{put.id, put.created, sha, in.kind};
  if (judges_) out.conformance = Conformance(put.id);
  return out;
}

namespace {

// The measurement's own result: the newest stored one (results are appended as analysis
// versions are added) other than the joints estimates kept with servo records, which are
// answered elsewhere; null when there is none.
const ResultRecord* OwnResult(const std::vector<ResultRecord>& results) {
  for (auto r = results.rbegin(); r != results.rend(); ++r) {
    if (r->analysis != kJointsAnalysis) return &*r;
  }
  return results.empty() ? nullptr : &results.back();
}

ConformanceSubject SubjectOf(const MeasurementRecord& r) {
  return {r.machine_id, r.kind, r.test_id, r.direction};
}

std::vector<ResultRecord> ResultsOrRefuse(MeasurementStore& store, MeasurementId id) {
  auto results = store.GetResults(id);
  if (results.empty()) {
    // One query in the common case; the second only tells the two refusals apart.
    if (!store.GetMeasurement(id)) {
      throw NotFound("measurement " + to_string(id) + " does not exist");
    }
    throw NotFound("measurement " + to_string(id) + " has no stored results");
  }
  return results;
}

}  // namespace

nlohmann::json MeasurementService::Results(MeasurementId id) {
  const auto results = ResultsOrRefuse(store_, id);
  return *parsed_.Parse(OwnResult(results)->result_json);
}

nlohmann::json MeasurementService::ResultsWithConformance(MeasurementId id) {
  const auto results = ResultsOrRefuse(store_, id);
  nlohmann::json j = *parsed_.Parse(OwnResult(results)->result_json);
  if (!judges_) return j;
  nlohmann::json conformance = judges_()(CachedSubject(id), j);
  if (j.is_object()) j["conformance"] = std::move(conformance);
  return j;
}

std::shared_ptr<const std::string> MeasurementService::ResultsAnswer(MeasurementId id) {
  const AnswerBasis basis = store_.GetAnswerBasis(id);
  const bool keepable = basis.results.count > 0;  // otherwise refused below
  if (keepable) {
    if (auto kept = answers_.Find(id, basis)) return kept;
  }
  // Made from what storage holds now, which is the basis read above or newer: kept under the
  // older basis, it is made again at the next request, never served stale.
  auto answer = std::make_shared<const std::string>(AnswerText(ResultsWithConformance(id)));
  if (keepable) answers_.Keep(id, basis, answer);
  return answer;
}

ConformanceSubject MeasurementService::CachedSubject(MeasurementId id) {
  {
    std::lock_guard lock(subjects_mu_);
    if (const auto it = subjects_.find(id); it != subjects_.end()) return it->second;
  }
  const auto rec = store_.GetMeasurement(id);
  if (!rec) throw NotFound("measurement " + to_string(id) + " does not exist");
  ConformanceSubject s = SubjectOf(*rec);
  std::lock_guard lock(subjects_mu_);
  if (subjects_.size() >= 4096) subjects_.clear();
  subjects_.emplace(id, s);
  return s;
}

nlohmann::json MeasurementService::Conformance(MeasurementId id) {
  const auto rec = store_.GetMeasurement(id);
  if (!rec) throw NotFound("measurement " + to_string(id) + " does not exist");
  if (!judges_) return nullptr;
  return Judge(judges_(), *rec, store_.GetResults(id));
}

nlohmann::json MeasurementService::Judge(const ConformanceJudge& judge, const MeasurementRecord& r,
                                         const std::vector<ResultRecord>& results) const {
  const ResultRecord* own = OwnResult(results);
  const nlohmann::json result =
      own ? ingest::ParseJsonTextOrDiscarded(own->result_json) : nlohmann::json(nullptr);
  return judge(SubjectOf(r), result.is_discarded() ? nlohmann::json(nullptr) : result);
}

nlohmann::json MeasurementService::MeasurementJson(const MeasurementRecord& r) const {
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
    {"positioning", "positioning", "accuracy_um", "positioning accuracy A (ISO 230-2)"},
    {"rotary", "rotary", "residual_rms_um", "residual RMS after the location errors"},
};

// {"name", "label", "value", "unit"} from the measurement's own result (of `analysis`, parsed),
// or null.
nlohmann::json KeyResultJson(const std::string& kind, const std::string& analysis,
                             const nlohmann::json& j) {
  for (const auto& k : kKeyFigures) {
    if (kind != k.kind || analysis != k.analysis) continue;
    if (!j.is_object() || !j.contains(k.key) || !j[k.key].is_number()) return nullptr;
    return {{"name", k.key}, {"label", k.label}, {"value", j[k.key]}, {"unit", "µm"}};
  }
  return nullptr;
}

}  // namespace

nlohmann::json MeasurementService::ListMeasurements(const MeasurementFilter& filter) {
  const auto page = store_.ListMeasurements(filter);
  const ConformanceJudge judge = judges_ ? judges_() : nullptr;  // one for the page
  nlohmann::json items = nlohmann::json::array();
  for (const auto& r : page.items) {
    nlohmann::json j = MeasurementJson(r);
    const auto results = store_.GetResults(r.id);
    const ResultRecord* own = OwnResult(results);
    // The own result is parsed once, for the key figure and the conformance.
    nlohmann::json result =
        own ? ingest::ParseJsonTextOrDiscarded(own->result_json) : nlohmann::json(nullptr);
    if (result.is_discarded()) result = nullptr;
    j["key_result"] = KeyResultJson(r.kind, own ? own->analysis : "", result);
    if (judge) j["conformance"] = judge(SubjectOf(r), result);
    items.push_back(std::move(j));
  }
  return {{"items", items}, {"total", page.total}};
}

nlohmann::json MeasurementService::MeasurementWithSamples(MeasurementId id) {
  const auto rec = store_.GetMeasurement(id);
  if (!rec) throw NotFound("measurement " + to_string(id) + " does not exist");
  nlohmann::json j = MeasurementJson(*rec);
  j["metadata"] = ingest::ParseJsonText(rec->metadata_json, "stored document");
  const auto block = store_.GetSamples(id);
  nlohmann::json samples = nlohmann::json::object();
  for (std::size_t c = 0; c < block.columns.size(); ++c) {
    samples[block.columns[c]] = block.Column(c);
  }
  j["samples"] = samples;
  j["partner_id"] = nlohmann::json(nullptr);
  if (const auto partner = PartnerOf(*rec)) j["partner_id"] = *partner;
  if (judges_) j["conformance"] = Judge(judges_(), *rec, store_.GetResults(id));
  return j;
}

std::optional<MeasurementId> MeasurementService::PartnerOf(const MeasurementRecord& rec) {
  if (rec.kind == "dbb" && (rec.direction == "ccw" || rec.direction == "cw")) {
    return DbbPartner(rec);
  }
  if (rec.kind == "straightness" && (rec.direction == "a" || rec.direction == "b")) {
    return NearestPartner(rec, rec.direction == "a" ? "b" : "a");
  }
  return std::nullopt;
}

std::vector<MachineSummary> MeasurementService::Machines() {
  return store_.ListMachines();
}

dbb::DbbTest MeasurementService::LoadDbb(MeasurementId id, MeasurementRecord* record) {
  const auto rec = store_.GetMeasurement(id);
  if (!rec) throw NotFound("measurement " + to_string(id) + " does not exist");
  if (rec->kind != "dbb") {
    throw InvalidInput("", 0, "id", "measurement " + to_string(id) + " is not a DBB test");
  }
  if (record) *record = *rec;
  dbb::DbbTest test = ingest::ReadDbb(store_.GetRaw(id), rec->filename);
  // The analyses made again from the stored bytes (pair, trace) read the instrument register's
  // uncertainties the way the upload did (its newest values, where the file states none).
  UseInstrument(instruments_, test.metadata, test.timestamp);
  return test;
}

std::optional<MeasurementId> MeasurementService::DbbPartner(const MeasurementRecord& rec) {
  return NearestPartner(rec, rec.direction == "ccw" ? "cw" : "ccw");
}

std::optional<MeasurementId> MeasurementService::NearestPartner(
    const MeasurementRecord& rec, const std::string& other_direction) {
  // The other-direction measurement (the opposite DBB direction, the other set-up of a
  // reversal) of the same machine, kind and test_id measured nearest in time to this one
  // (measurement time, else upload time): a pair is run minutes apart, a repeat days or months
  // later. On equal distance the one stored nearest, then the later.
  const std::string when = rec.measured_at.value_or(rec.uploaded_at);
  const auto t = ingest::Iso8601EpochSeconds(when);
  MeasurementFilter f;
  f.machine_id = rec.machine_id;
  f.kind = rec.kind;
  f.test_id = rec.test_id;
  f.direction = other_direction;
  f.limit = 2;
  std::vector<MeasurementRecord> candidates;
  f.from = when;  // the nearest at or after it
  f.order = MeasurementFilter::Order::kOldest;
  for (auto& m : store_.ListMeasurements(f).items) candidates.push_back(std::move(m));
  f.from.reset();
  f.to = when;  // the nearest before it
  f.order = MeasurementFilter::Order::kNewest;
  for (auto& m : store_.ListMeasurements(f).items) candidates.push_back(std::move(m));
  std::optional<MeasurementId> best;
  double best_dt = 0.0;
  const auto apart = [&rec](MeasurementId id) { return std::abs(id.value() - rec.id.value()); };
  for (const auto& m : candidates) {
    const auto tm = ingest::Iso8601EpochSeconds(m.measured_at.value_or(m.uploaded_at));
    const double dt = t && tm ? std::fabs(*tm - *t) : 0.0;
    const bool nearer = !best || dt < best_dt ||
                        (dt == best_dt && (apart(m.id) < apart(*best) ||
                                           (apart(m.id) == apart(*best) && m.id > *best)));
    if (nearer) {
      best = m.id;
      best_dt = dt;
    }
  }
  return best;
}

nlohmann::json MeasurementService::DbbTrace(MeasurementId id) {
  const dbb::DbbTest test = LoadDbb(id);
  return usecases::DbbTraceJson(test,
                                dbb::AnalyzeCircularTest(test, dbb::DeviationUnits::kToolPath));
}

nlohmann::json MeasurementService::DbbPairJson(MeasurementId id) {
  MeasurementRecord rec;
  const dbb::DbbTest test = LoadDbb(id, &rec);
  const auto partner = DbbPartner(rec);
  if (!partner) return nullptr;
  const dbb::DbbTest other = LoadDbb(*partner);
  const std::vector<dbb::DbbTest> both{test, other};
  const dbb::DbbReport report = dbb::AnalyzeDbbSet(both);
  const nlohmann::json j = usecases::DbbReportJson(both, report);
  nlohmann::json out;
  out["partner_id"] = *partner;
  if (!j["pairs"].empty()) {
    out["pair"] = j["pairs"][0];
  }
  out["joint_diagnosis"] = j["tests"][0]["diagnosis"];
  out["joint_not_identifiable"] = j["tests"][0]["not_identifiable"];
  out["partner_joint_diagnosis"] = j["tests"][1]["diagnosis"];
  return out;
}

std::string MeasurementService::DbbPlotPng(MeasurementId id,
                                           const render::PolarPlotOptions& options) {
  MeasurementRecord rec;
  std::vector<dbb::DbbTest> tests{LoadDbb(id, &rec)};
  if (const auto partner = DbbPartner(rec)) tests.push_back(LoadDbb(*partner));
  const dbb::DbbReport report = dbb::AnalyzeDbbSet(tests);
  const auto png = render::DbbPolarPlotPng(report, 0, options);
  return std::string(png.begin(), png.end());
}

nlohmann::json MeasurementService::StraightnessReversalJson(MeasurementId id) {
  const auto rec = store_.GetMeasurement(id);
  if (!rec) throw NotFound("measurement " + to_string(id) + " does not exist");
  if (rec->kind != "straightness") {
    throw InvalidInput("", 0, "id",
                       "measurement " + to_string(id) + " is not a straightness profile");
  }
  if (rec->direction != "a" && rec->direction != "b") {
    throw InvalidInput(
        "", 0, "reversal",
        "measurement " + to_string(id) +
            " is not one set-up of a reversal pair (its file has no `reversal` key)");
  }
  const auto partner = NearestPartner(*rec, rec->direction == "a" ? "b" : "a");
  if (!partner) return nullptr;
  const auto other = store_.GetMeasurement(*partner);
  std::vector<ingest::StraightnessFile> files;
  for (const auto& [mid, name] :
       {std::pair{id, rec->filename}, std::pair{*partner, other->filename}})
    files.push_back(ingest::ParseStraightnessFile(store_.GetRaw(mid), name));
  if (files[0].reversal == "b") std::swap(files[0], files[1]);
  const nlohmann::json j = usecases::StraightnessFilesToJson(files);
  nlohmann::json out;
  out["partner_id"] = *partner;
  out["reversal"] = j.value("reversal", nlohmann::json(nullptr));
  out["profiles"] = j["profiles"];
  return out;
}

std::string MeasurementService::PositioningCompensation(MeasurementId id,
                                                        const std::string& format) {
  const auto rec = store_.GetMeasurement(id);
  if (!rec) throw NotFound("measurement " + to_string(id) + " does not exist");
  if (rec->kind != "positioning") {
    throw InvalidInput("", 0, "id",
                       "measurement " + to_string(id) + " is not a laser positioning test");
  }
  const auto report =
      usecases::AnalyzePositioning(ingest::ParsePositioningFile(store_.GetRaw(id), rec->filename));
  try {
    return usecases::ExportCompensation(report, format);
  } catch (const InvalidInput& e) {
    throw InvalidInput("", 0, "format", e.reason());
  }
}

void RegisterBuiltinKinds(MeasurementService& measurements) {
  for (auto& f : BuiltinFormats()) measurements.RegisterKind(f.format, std::move(f.handler));
}

}  // namespace km::server
