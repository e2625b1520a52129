// How the measurement service completes a file naming an instrument from the instrument
// register without knowing the register: the service that keeps it (server/instruments/) gives
// a hook, wired in server/service.cpp. Each format's handler runs the hook on the parsed file's
// header keys after parsing and before the analysis (so the analysis reads the register's u_*
// keys where the file states none), then adds what the hook says to the result it stores
// (docs/http.md "Instruments"). The stored file itself is never changed.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace km::server {

// What the register added to a file, for its result.
struct InstrumentUse {
  // The result's "instrument" object: {instrument, serial, calibrated, certificate,
  // register_version, sources, calibration_due, overdue}, or null when the file names no
  // instrument.
  nlohmann::json block = nullptr;
  std::vector<std::string> warnings;  // e.g. the instrument was past its calibration interval
};

// Adds to `metadata` (every header key of a parsed file) the instrument keys and u_* keys the
// register holds for the file's instrument_serial and the file does not state itself.
// `measured_at`: the file's own time as written (none: the upload time).
using InstrumentHook = std::function<InstrumentUse(std::map<std::string, std::string>& metadata,
                                                   const std::optional<std::string>& measured_at)>;

// The hook's answer, or nullopt when there is no hook (the result then gets no "instrument").
inline std::optional<InstrumentUse> UseInstrument(const InstrumentHook& hook,
                                                  std::map<std::string, std::string>& metadata,
                                                  const std::optional<std::string>& measured_at) {
  if (!hook) return std::nullopt;
  return hook(metadata, measured_at);
}

// Adds "instrument" and the warnings (appended to the array "warnings", made when absent) to a
// result.
inline void AddInstrumentUse(const std::optional<InstrumentUse>& use, nlohmann::json& result) {
  if (!use || !result.is_object()) return;
  result["instrument"] = use->block;
  if (use->warnings.empty()) return;
  if (!result.contains("warnings")) result["warnings"] = nlohmann::json::array();
  if (!result["warnings"].is_array()) return;
  for (const auto& w : use->warnings) result["warnings"].push_back(w);
}

}  // namespace km::server
