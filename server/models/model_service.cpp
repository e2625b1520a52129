// Machine definitions kept by the server, versioned: an uploaded document, a calibration's
// calibrated machine or a discovery's updated machine becomes the next version of its machine's
// model; nothing is overwritten. Studies name a stored model by machine_id (and version).
#include <cstdint>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "ingest/machine_json.h"
#include "server/base/sha256.h"
#include "server/models/model_service.h"

namespace km::server {

namespace {

constexpr std::size_t kMaxNoteBytes = 4096;

std::string VersionText(const std::string& machine_id, std::int64_t version) {
  return "machine '" + machine_id + "' version " + std::to_string(version);
}

}  // namespace

MachineModelStored ModelService::StoreMachineModel(std::string_view bytes,
                                                   const std::string& source,
                                                   const std::string& note,
                                                   const std::string& file) {
  if (bytes.size() > kMaxMachineModelBytes) {
    throw TooLarge(file, 0, "",
                   "the machine definition is " + std::to_string(bytes.size()) +
                       " bytes; the limit is " + std::to_string(kMaxMachineModelBytes));
  }
  if (note.size() > kMaxNoteBytes) {
    throw InvalidInput(file, 0, "note",
                       "the note is longer than " + std::to_string(kMaxNoteBytes) + " bytes");
  }
  const ingest::MachineDefinition machine = ingest::ParseMachineJson(bytes, file);
  NewMachineModel m;
  m.machine_id = machine.machine_id;
  m.source = source;
  m.note = note;
  m.document.assign(bytes);
  m.sha256 = Sha256Hex(bytes);
  const MachineModelPut put = store_.PutMachineModel(m);
  return MachineModelStored{put.record.machine_id, put.record.version, put.record.created_at,
                            put.created};
}

MachineModelRecord ModelService::GetMachineModel(const std::string& machine_id,
                                                 std::optional<std::int64_t> version) {
  auto rec = store_.GetMachineModel(machine_id, version);
  if (rec) return std::move(*rec);
  if (!version) throw NotFound("machine '" + machine_id + "' has no stored model");
  const auto newest = store_.GetMachineModel(machine_id, std::nullopt);
  if (!newest) throw NotFound("machine '" + machine_id + "' has no stored model");
  throw NotFound("machine '" + machine_id + "' has no model version " + std::to_string(*version) +
                 " (the newest is version " + std::to_string(newest->version) + ")");
}

nlohmann::json ModelService::ListMachineModels(const std::string& machine_id) {
  const auto versions = store_.ListMachineModels(machine_id);
  if (versions.empty()) throw NotFound("machine '" + machine_id + "' has no stored model");
  nlohmann::json items = nlohmann::json::array();
  for (const auto& v : versions) {
    items.push_back({{"version", v.version},
                     {"created_at", v.created_at},
                     {"source", v.source},
                     {"note", v.note},
                     {"sha256", v.sha256}});
  }
  return {{"machine_id", machine_id}, {"versions", items}};
}

ingest::MachineDefinition ModelService::RequestedMachine(const ModelRef& ref,
                                                         std::int64_t& version) {
  const MachineModelRecord rec = GetMachineModel(ref.machine_id, ref.version);
  version = rec.version;
  // Stored documents were validated when they were stored; parsed again for this study.
  return ingest::ParseMachineJson(rec.document, VersionText(rec.machine_id, rec.version));
}

}  // namespace km::server
