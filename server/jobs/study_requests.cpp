#include "server/jobs/study_requests.h"

#include <algorithm>
#include <limits>

#include "analysis/core/errors.h"
#include "analysis/hexapod/effects/registry.h"
#include "server/base/request_json.h"
#include "usecases/calibration_study.h"

namespace km::server {
namespace {

namespace req = km::server::request;

void RequireObject(const nlohmann::json& body) {
  if (!body.is_object()) throw InvalidInput("request", 0, "", "the body must be a JSON object");
}

// "machine_id" and, optionally, "machine_version" (else the newest).
ModelRef ParseModelRef(const nlohmann::json& body) {
  ModelRef ref{req::RequiredString(body, "machine_id"), std::nullopt};
  if (body.contains("machine_version")) {
    ref.version =
        req::WholeNumber(body, "machine_version", 1, std::numeric_limits<std::int64_t>::max());
  }
  return ref;
}

void PutModelRef(const ModelRef& ref, nlohmann::json& out) {
  out["machine_id"] = ref.machine_id;
  if (ref.version) out["machine_version"] = *ref.version;
}

// The measurement ids: a non-empty list of whole numbers ≥ 1 (how many, and each once:
// StudyService, which knows the limit and refuses a list that is too long first).
std::vector<std::int64_t> MeasurementIds(const nlohmann::json& body) {
  if (!body.contains("measurement_ids") || !body["measurement_ids"].is_array() ||
      body["measurement_ids"].empty()) {
    throw InvalidInput("request", 0, "measurement_ids", "a non-empty list of DBB measurement ids");
  }
  std::vector<std::int64_t> ids;
  for (const auto& v : body["measurement_ids"]) {
    const bool whole = v.is_number_integer() &&
                       !(v.is_number_unsigned() &&
                         v.get<std::uint64_t>() >
                             static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()));
    if (!whole || v.get<std::int64_t>() < 1) {
      throw InvalidInput("request", 0, "measurement_ids",
                         "ids must be whole numbers from 1 (entry " +
                             std::to_string(ids.size() + 1) + " is " +
                             v.dump(-1, ' ', true).substr(0, 40) + ")");
    }
    ids.push_back(v.get<std::int64_t>());
  }
  return ids;
}

// `effects`: a list of hexapod effect names, each once.
std::vector<std::string> EffectNames(const nlohmann::json& body) {
  std::vector<std::string> names;
  if (!body.contains("effects")) return names;
  const auto& list = body["effects"];
  if (!list.is_array() || list.size() > 16)
    throw InvalidInput("request", 0, "effects", "a list of hexapod effect names");
  for (const auto& v : list) {
    if (!v.is_string() || !hexapod::FindHexapodEffect(v.get<std::string>())) {
      throw InvalidInput("request", 0, "effects",
                         "each entry must be one of " + hexapod::HexapodEffectNames());
    }
    if (std::find(names.begin(), names.end(), v.get<std::string>()) != names.end())
      throw InvalidInput("request", 0, "effects", v.get<std::string>() + " is listed twice");
    names.push_back(v.get<std::string>());
  }
  return names;
}

std::optional<int> OptionalInt(const nlohmann::json& body, const std::string& key, int lo, int hi) {
  if (!body.contains(key)) return std::nullopt;
  return static_cast<int>(req::WholeNumber(body, key, lo, hi));
}

// The machine of a calibration: an inline definition or a stored model, not both.
void ParseCalibrationMachine(const nlohmann::json& body, CalibrationRequest& r) {
  if (body.contains("machine")) {
    if (!body["machine"].is_object()) {
      throw InvalidInput("request", 0, "machine",
                         "the hexapod machine definition (docs/formats.md §2) must be an object");
    }
    if (body.contains("machine_id") || body.contains("machine_version")) {
      throw InvalidInput("request", 0, "machine_id",
                         "give either the machine definition (machine) or a stored model "
                         "(machine_id, machine_version), not both");
    }
    r.machine = body["machine"];
  } else if (body.contains("machine_id")) {
    r.model = ParseModelRef(body);
  } else {
    throw InvalidInput(
        "request", 0, "machine",
        "the hexapod machine definition (docs/formats.md §2) is required as an object, "
        "or machine_id naming a stored model");
  }
}

}  // namespace

CalibrationRequest CalibrationRequest::Parse(const nlohmann::json& body) {
  RequireObject(body);
  CalibrationRequest r;
  ParseCalibrationMachine(body, r);
  if (body.contains("method")) {
    if (!body["method"].is_string()) {
      throw InvalidInput("request", 0, "method", "absolute or centre-corrected");
    }
    try {
      r.method = usecases::ParseCalibrationMethod(body["method"].get<std::string>(), "method");
    } catch (const InvalidInput& e) {
      throw InvalidInput("request", 0, "method", e.reason());  // named like every other field
    }
  }
  r.reduction_study_min_tests = OptionalInt(body, "reduction_study_min_tests", 1, 1000);
  r.effects = EffectNames(body);
  r.max_samples_per_test = OptionalInt(body, "max_samples_per_test", 0, 10'000'000);
  r.measurement_ids = MeasurementIds(body);
  return r;
}

nlohmann::json CalibrationRequest::ToJson() const {
  nlohmann::json out = {{"measurement_ids", measurement_ids}};
  if (machine) out["machine"] = *machine;
  if (model) PutModelRef(*model, out);
  if (method) {
    out["method"] =
        *method == hexapod::CalibrationMethod::kAbsolute ? "absolute" : "centre-corrected";
  }
  if (reduction_study_min_tests) out["reduction_study_min_tests"] = *reduction_study_min_tests;
  if (max_samples_per_test) out["max_samples_per_test"] = *max_samples_per_test;
  if (!effects.empty()) out["effects"] = effects;
  return out;
}

DiscoveryRequest DiscoveryRequest::Parse(const nlohmann::json& body) {
  RequireObject(body);
  if (body.contains("machine")) {
    throw InvalidInput("request", 0, "machine",
                       "a discovery study takes a stored model: store the machine definition "
                       "(POST /api/v1/machines) and name it with machine_id");
  }
  DiscoveryRequest r;
  if (body.contains("machine_id")) {
    r.model = ParseModelRef(body);
  } else if (body.contains("machine_version")) {
    throw InvalidInput("request", 0, "machine_version", "needs machine_id (the stored model)");
  }
  r.max_samples_per_test = OptionalInt(body, "max_samples_per_test", 0, 10'000'000);
  r.measurement_ids = MeasurementIds(body);
  return r;
}

nlohmann::json DiscoveryRequest::ToJson() const {
  nlohmann::json out = {{"measurement_ids", measurement_ids}};
  if (model) PutModelRef(*model, out);
  if (max_samples_per_test) out["max_samples_per_test"] = *max_samples_per_test;
  return out;
}

}  // namespace km::server
