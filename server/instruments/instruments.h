// The instrument register (docs/http.md "Instruments"): each measuring instrument — a laser
// interferometer, a ballbar, a straightedge, a level, a tracker — with its standard
// uncertainties (k = 1, the u_* keys of the measurement files, docs/formats.md "Instrument
// keys (every kind)"), its calibration date, interval and certificate. A file naming a
// registered instrument_serial takes the register's values for every key it does not state
// itself; a result measured after the instrument's calibration was due carries a warning.
//
// This file is pure (no I/O): the body of PUT /api/v1/instruments/{serial}, the JSON of an
// entry, and completing a file's header keys from an entry. Storing the versions is
// server/instruments/instrument_service.h.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/measurements/instrument_hook.h"

namespace km::server {

inline constexpr std::int64_t kMaxCalibrationIntervalDays = 3660;

// The instrument kinds of the register: laser, ballbar, straightness, level, tracker, other.
const std::vector<std::string>& InstrumentKinds();
// The uncertainty keys the register keeps (the u_* keys the analyses read, and the bar's
// expansion coefficient of a ballbar): u_laser_ppm, u_air_temperature_c, u_air_pressure_pa,
// u_air_humidity_pct, u_material_temperature_c, u_expansion_ppm_per_k, u_reading_um,
// u_bar_length_um, u_bar_temperature_c, bar_expansion_ppm_per_k, u_ranging_um.
const std::vector<std::string>& InstrumentUncertaintyKeys();

// One version of an instrument of the register.
struct Instrument {
  std::string serial;
  std::int64_t version = 0;                     // 1, 2, … as stored
  std::string created_at;                       // ISO 8601 UTC
  std::string instrument;                       // the instrument's name, e.g. "Renishaw XL-80"
  std::string kind;                             // one of InstrumentKinds()
  std::map<std::string, double> uncertainties;  // keys of InstrumentUncertaintyKeys(), ≥ 0
  std::optional<std::string> calibrated;        // YYYY-MM-DD
  std::optional<std::int64_t> calibration_interval_days;  // 1 … kMaxCalibrationIntervalDays
  std::optional<std::string> certificate;
};

// The body of PUT /api/v1/instruments/{serial}: {"instrument" (required), "kind" (required),
// "uncertainties": {KEY: number ≥ 0}, "calibrated": "YYYY-MM-DD", "calibration_interval_days",
// "certificate"} (the optional ones may be null). km::InvalidInput naming the field
// ("uncertainties.u_laser_ppm", "calibrated", "colour" for an unknown key, "body"). Serial,
// version and created_at are left empty.
Instrument ParseInstrumentBody(const nlohmann::json& body);
// The entry as stored and hashed: the body's fields, absent ones null.
nlohmann::json InstrumentBodyJson(const Instrument& instrument);
// {serial, version, created_at, instrument, kind, uncertainties, calibrated,
//  calibration_interval_days, calibration_due, certificate}.
nlohmann::json InstrumentJson(const Instrument& instrument);
// calibrated + calibration_interval_days as YYYY-MM-DD, when both are known.
std::optional<std::string> CalibrationDue(const Instrument& instrument);

// Completes `metadata` (a parsed file's header keys) from `registered` (the register's entry of
// the file's instrument_serial, if any) and says how (server/measurements/instrument_hook.h):
// every uncertainty key and the instrument, instrument_calibrated and instrument_certificate
// keys the file does not state are copied in; the block names the source of every u_* key; a
// measurement made (`measured_at`, else `upload_epoch_s`) on a day after the calibration was
// due is overdue, with a warning. A file without instrument keys: block null, nothing copied.
InstrumentUse ApplyInstrument(std::map<std::string, std::string>& metadata,
                              const std::optional<Instrument>& registered,
                              const std::optional<std::string>& measured_at, double upload_epoch_s);

}  // namespace km::server
