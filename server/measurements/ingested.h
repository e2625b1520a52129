// What the handler of a kind of measurement makes of one file before it is stored (the upload,
// server/measurements/kinds.h): the record, its samples and the results computed at upload.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/measurements/instrument_hook.h"
#include "server/storage/storage.h"

namespace km::server {

// What one kind of measurement file turns into before it is stored.
struct Ingested {
  std::string kind;
  std::string machine_id, test_id, direction;
  std::optional<std::string> measured_at;  // as written in the file
  nlohmann::json metadata = nlohmann::json::object();
  SampleBlock samples;
  std::vector<NewResult> results;  // computed at upload, stored in the same transaction
};

// Parses and analyses one file of a format; throws km::InvalidInput naming file/line/field.
// `instruments` (may be empty) completes the parsed header keys from the instrument register
// before the analysis (server/measurements/instrument_hook.h); `metadata` keeps the file's own.
using KindHandler = std::function<Ingested(std::string_view bytes, const std::string& file,
                                           const InstrumentHook& instruments)>;

}  // namespace km::server
