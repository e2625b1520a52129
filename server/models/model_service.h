// Machine definitions kept by the server ("kinemetric-machine/1", docs/formats.md §2),
// versioned: an uploaded document, a calibration's calibrated machine or a discovery's updated
// machine becomes the next version of its machine's model; nothing is overwritten. Studies name
// a stored model by machine_id (and version).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "ingest/machine_json.h"
#include "server/storage/storage.h"

namespace km::server {

// The largest machine definition the service stores (a hexapod document with gravity,
// friction and discovered effects is a few KiB).
inline constexpr std::size_t kMaxMachineModelBytes = 1u << 20;

// One stored version of a machine definition.
struct MachineModelStored {
  std::string machine_id;
  std::int64_t version = 0;
  std::string created_at;
  bool created = false;  // false: the bytes were those of the newest version already
};

// A stored machine model named by a request: its id and a version (unset: the newest).
struct ModelRef {
  std::string machine_id;
  std::optional<std::int64_t> version;
};

class ModelService {
 public:
  explicit ModelService(ModelStore& store) : store_(store) {}

  // Validates the document (ingest::ParseMachineJson: InvalidInput naming `file` and the field;
  // TooLarge beyond kMaxMachineModelBytes) and appends it as the next version of its machine_id,
  // with its source ("upload", "calibration job N", "discovery job N") and note. The bytes of the
  // newest version again → that version, created = false.
  MachineModelStored StoreMachineModel(std::string_view bytes, const std::string& source,
                                       const std::string& note,
                                       const std::string& file = "machine");
  // A version with its document (the newest without one); NotFound names machine and version.
  MachineModelRecord GetMachineModel(const std::string& machine_id,
                                     std::optional<std::int64_t> version = std::nullopt);
  // {"machine_id", "versions": [{"version", "created_at", "source", "note", "sha256"}]},
  // oldest first; NotFound when the machine has no stored model.
  nlohmann::json ListMachineModels(const std::string& machine_id);
  // The stored model a request names (the newest without a version), parsed; `version` is set
  // to the version used.
  ingest::MachineDefinition RequestedMachine(const ModelRef& ref, std::int64_t& version);

 private:
  ModelStore& store_;
};

}  // namespace km::server
