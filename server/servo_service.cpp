#include "server/servo_service.h"

#include <limits>
#include <set>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/machine_json.h"
#include "ingest/servo_parser.h"
#include "report/servo_report.h"
#include "server/request_json.h"

namespace km::server {
namespace {

namespace req = request;

struct Inputs {
  ingest::MachineDefinition machine;
  std::int64_t version = 0;
  std::vector<servo::ServoFile> files;
};

std::string MeasurementName(std::int64_t id, const std::string& filename) {
  return "measurement " + std::to_string(id) + " (" + filename + ")";
}

ingest::MachineDefinition Machine(Service& svc, const std::string& machine_id,
                                  std::optional<std::int64_t> version, std::int64_t& used) {
  const MachineModelRecord rec = svc.GetMachineModel(machine_id, version);
  used = rec.version;
  return ingest::ParseHexapodMachineJson(
      rec.document, "machine " + rec.machine_id + " version " + std::to_string(rec.version));
}

// The servo measurements of the request, read back and parsed, each of the machine.
std::vector<servo::ServoFile> Files(Service& svc, const nlohmann::json& request,
                                    const std::string& machine_id) {
  if (!request.contains("measurement_ids") || !request["measurement_ids"].is_array() ||
      request["measurement_ids"].empty()) {
    throw InvalidInput(req::kFile, 0, "measurement_ids",
                       "a non-empty list of servo measurement ids");
  }
  const auto& list = request["measurement_ids"];
  if (list.size() > kMaxServoMeasurements) {
    throw InvalidInput(req::kFile, 0, "measurement_ids",
                       "at most " + std::to_string(kMaxServoMeasurements) + " measurements");
  }
  std::vector<servo::ServoFile> files;
  std::set<std::int64_t> seen;
  std::size_t samples = 0;
  for (const auto& v : list) {
    if (!v.is_number_integer() || v.get<std::int64_t>() < 1 ||
        !seen.insert(v.get<std::int64_t>()).second) {
      throw InvalidInput(req::kFile, 0, "measurement_ids",
                         "ids are whole numbers from 1, each listed once");
    }
    const std::int64_t id = v.get<std::int64_t>();
    const auto rec = svc.storage().GetMeasurement(id);
    if (!rec) throw NotFound("measurement " + std::to_string(id) + " does not exist");
    if (rec->kind != "servo" || rec->machine_id != machine_id) {
      throw InvalidInput(
          req::kFile, 0, "measurement_ids",
          "measurement " + std::to_string(id) + " is not a servo record of " + machine_id);
    }
    files.push_back(
        ingest::ParseServoFile(svc.storage().GetRaw(id), MeasurementName(id, rec->filename)));
    samples += files.back().t_s.size();
    if (samples > kMaxServoSamples) {
      throw InvalidInput(req::kFile, 0, "measurement_ids",
                         "more than " + std::to_string(kMaxServoSamples) + " samples in all");
    }
  }
  return files;
}

Inputs Read(Service& svc, const nlohmann::json& request) {
  if (!request.is_object()) throw InvalidInput(req::kFile, 0, "", "a JSON object is required");
  Inputs in;
  const std::string machine_id = req::RequiredString(request, "machine_id");
  std::optional<std::int64_t> version;
  if (request.contains("machine_version")) {
    version =
        req::WholeNumber(request, "machine_version", 1, std::numeric_limits<std::int64_t>::max());
  }
  in.machine = Machine(svc, machine_id, version, in.version);
  in.files = Files(svc, request, machine_id);
  for (const auto& f : in.files) {
    if (!f.hexapod) {
      throw InvalidInput(req::kFile, 0, "measurement_ids",
                         f.file + " is a feed-drive record, not hexapod strut loads");
    }
  }
  return in;
}

}  // namespace

nlohmann::json ServoIdentify(Service& service, const nlohmann::json& request) {
  Inputs in = Read(service, request);
  const bool save =
      request.contains("save") && request["save"].is_boolean() && request["save"].get<bool>();
  if (request.contains("save") && !request["save"].is_boolean()) {
    throw InvalidInput(req::kFile, 0, "save", "must be true or false");
  }
  const std::string note = req::OptionalString(request, "note", "");
  const auto r = servo::IdentifyLoads(
      in.machine.geometry, in.machine.physics.value_or(hexapod::MachinePhysics{}), in.files);
  nlohmann::json j = ServoIdentifyJson(in.machine.machine_id, in.files, r);
  j["machine_version"] = in.version;
  if (save) {
    const auto stored = service.StoreMachineModel(MachineWithIdentified(in.machine, r),
                                                  "servo identification", note);
    j["saved"] = {{"machine_id", stored.machine_id},
                  {"version", stored.version},
                  {"created", stored.created}};
  }
  return j;
}

nlohmann::json ServoJoints(Service& service, const nlohmann::json& request) {
  Inputs in = Read(service, request);
  servo::JointOptions o;
  o.level2_ratio = req::Number(request, "level2_ratio", o.level2_ratio);
  o.level3_ratio = req::Number(request, "level3_ratio", o.level3_ratio);
  o.increase_warn = req::Number(request, "increase_warn", o.increase_warn);
  o.increase_stop = req::Number(request, "increase_stop", o.increase_stop);
  if (request.contains("previous")) {
    o.previous_Nm = PreviousResistances(request["previous"].dump(), "request previous");
  }
  try {
    o.Check();
  } catch (const InvalidInput& e) {
    throw InvalidInput(req::kFile, 0, e.field(), e.reason());
  }
  const auto r = servo::EstimateJointResistance(
      in.machine.geometry, in.machine.physics.value_or(hexapod::MachinePhysics{}), in.files, o);
  nlohmann::json j = ServoJointsJson(in.machine.machine_id, r, o);
  j["machine_version"] = in.version;
  return j;
}

nlohmann::json ServoForce(Service& service, std::int64_t measurement_id,
                          std::optional<std::int64_t> machine_version) {
  const auto rec = service.storage().GetMeasurement(measurement_id);
  if (!rec) throw NotFound("measurement " + std::to_string(measurement_id) + " does not exist");
  if (rec->kind != "servo") {
    throw InvalidInput("", 0, "id",
                       "measurement " + std::to_string(measurement_id) + " is not a servo record");
  }
  std::int64_t version = 0;
  const auto machine = Machine(service, rec->machine_id, machine_version, version);
  if (!machine.physics) {
    throw InvalidInput("", 0, "machine_id",
                       "the model of " + rec->machine_id +
                           " has no gravity and friction blocks (identify and save first)");
  }
  const auto file = ingest::ParseServoFile(service.storage().GetRaw(measurement_id),
                                           MeasurementName(measurement_id, rec->filename));
  if (!file.hexapod) {
    throw InvalidInput("", 0, "id", "a feed-drive record has no tool-tip force");
  }
  const auto f = servo::EstimateExternalForce(machine.geometry, *machine.physics, file,
                                              ForceOptionsOf(machine));
  nlohmann::json j = ServoForceJson(machine.machine_id, file, f);
  j["machine_version"] = version;
  return j;
}

}  // namespace km::server
