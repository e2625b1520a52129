// The instrument register, versioned (docs/http.md "Instruments"): PUT stores the next version
// of a serial (the same entry as the newest version gives that version back, nothing stored),
// GET reads the newest or one version, the list the newest version of every serial; the hook
// completes each uploaded file naming a registered serial before its analysis
// (server/measurements/instrument_hook.h). The pure parts are server/instruments/instruments.h.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "server/instruments/instruments.h"
#include "server/measurements/instrument_hook.h"
#include "server/storage/storage.h"

namespace km::server {

class InstrumentService {
 public:
  explicit InstrumentService(InstrumentStore& store) : store_(store) {}

  // PUT /api/v1/instruments/{serial}: InstrumentJson + "created". km::InvalidInput naming the
  // field (serial, instrument, uncertainties.u_laser_ppm, …).
  nlohmann::json Put(const std::string& serial, const nlohmann::json& body);
  // GET /api/v1/instruments/{serial}[?version=N]: InstrumentJson; NotFound when the serial is
  // not registered (or not that version).
  nlohmann::json Get(const std::string& serial, std::optional<std::int64_t> version);
  // GET /api/v1/instruments: {"items": [InstrumentJson of the newest version of each serial, by
  // serial], "total"}.
  nlohmann::json List();
  // The newest version of a serial; nullopt when it is not registered.
  std::optional<Instrument> Find(const std::string& serial);

  // The hook of the measurement service: the newest version of the file's serial, read at each
  // upload.
  InstrumentHook Hook();

 private:
  InstrumentStore& store_;
};

}  // namespace km::server
