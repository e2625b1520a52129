// The measurement formats the service takes (docs/formats.md §1): one registration record a
// format — its name (ingest's constant), what an upload of it may hold by default, and the
// handler that parses, analyses and turns a file into what is stored. A new format is one line
// of BuiltinFormats (server/measurements/kinds.cpp).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "ingest/text_format.h"
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

// One format as the service knows it.
struct FormatRegistration {
  std::string format;         // e.g. "kinemetric-dbb/1"
  ingest::TextLimits limits;  // default upload limits (ServiceOptions::upload_limits)
  KindHandler handler;
};

// Every built-in format, one record each (tracker, DBB, straightness, flatness, parallelism,
// servo loads).
std::vector<FormatRegistration> BuiltinFormats();

}  // namespace km::server
