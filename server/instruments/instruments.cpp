#include "server/instruments/instruments.h"

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"
#include "ingest/identifiers.h"
#include "ingest/iso8601.h"
#include "ingest/text_format.h"

namespace km::server {
namespace {

using nlohmann::json;

[[noreturn]] void RefuseField(const std::string& field, const std::string& why) {
  throw InvalidInput("", 0, field, why);
}

bool OneOf(const std::vector<std::string>& list, const std::string& s) {
  return std::find(list.begin(), list.end(), s) != list.end();
}

const std::vector<std::string>& BodyKeys() {
  static const std::vector<std::string> keys = {
      "instrument", "kind", "uncertainties", "calibrated", "calibration_interval_days",
      "certificate"};
  return keys;
}

std::string Joined(const std::vector<std::string>& list) {
  std::string out;
  for (const auto& s : list) out += (out.empty() ? "" : ", ") + s;
  return out;
}

// Free text of the entry: a string of 1 to kMaxInstrumentTextBytes bytes that may be shown
// anywhere (no line break, control or invisible character).
std::string EntryText(const json& v, const std::string& field) {
  if (!v.is_string() || v.get<std::string>().empty()) {
    RefuseField(field, "must be a non-empty string");
  }
  const std::string s = v.get<std::string>();
  if (s.size() > ingest::kMaxInstrumentTextBytes) {
    RefuseField(field,
                "is longer than " + std::to_string(ingest::kMaxInstrumentTextBytes) + " bytes");
  }
  if (const auto bad = ingest::ForbiddenCharacter(s)) {
    RefuseField(field, "holds " + *bad +
                           "; it may not hold line breaks, control or invisible formatting "
                           "characters");
  }
  return s;
}

std::map<std::string, double> Uncertainties(const json& u) {
  if (!u.is_object()) RefuseField("uncertainties", "must be an object {KEY: number, …}");
  std::map<std::string, double> out;
  for (const auto& [key, value] : u.items()) {
    const std::string field = "uncertainties." + key;
    if (!OneOf(InstrumentUncertaintyKeys(), key)) {
      RefuseField(field, "is not an uncertainty the register keeps (" +
                             Joined(InstrumentUncertaintyKeys()) + ")");
    }
    if (!value.is_number() || !std::isfinite(value.get<double>())) {
      RefuseField(field, "must be a finite number");
    }
    const double v = value.get<double>();
    if (v < 0 || v > ingest::kMaxStandardUncertainty) {
      RefuseField(field,
                  "must be from 0 to 1e6 (a standard uncertainty, k = 1, in the key's unit)");
    }
    out[key] = v;
  }
  return out;
}

std::string CalibratedDate(const json& v) {
  if (!v.is_string() || !ingest::IsoDateDays(v.get<std::string>())) {
    RefuseField("calibrated", "must be a calendar date written \"YYYY-MM-DD\"");
  }
  return v.get<std::string>();
}

std::int64_t IntervalDays(const json& v) {
  if (!v.is_number_integer()) {
    RefuseField("calibration_interval_days", "must be a whole number of days");
  }
  // Beyond the range of int64 an integer is unsigned; read as such it is out of range.
  const bool in_range =
      v.is_number_unsigned()
          ? v.get<std::uint64_t>() <= static_cast<std::uint64_t>(kMaxCalibrationIntervalDays)
          : v.get<std::int64_t>() <= kMaxCalibrationIntervalDays;
  if (!in_range || v.get<std::int64_t>() < 1) {
    RefuseField("calibration_interval_days",
                "must be from 1 to " + std::to_string(kMaxCalibrationIntervalDays) + " days");
  }
  return v.get<std::int64_t>();
}

// The number as a header value (the shortest text that reads back as the same double).
std::string NumberText(double v) {
  return json(v).dump();
}

bool IsUncertaintyKey(const std::string& key) {
  return key.rfind("u_", 0) == 0 || OneOf(InstrumentUncertaintyKeys(), key);
}

json TextOrNull(const std::map<std::string, std::string>& m, const std::string& key) {
  const auto it = m.find(key);
  return it == m.end() ? json(nullptr) : json(it->second);
}

}  // namespace

const std::vector<std::string>& InstrumentKinds() {
  static const std::vector<std::string> kinds = {"laser", "ballbar", "straightness",
                                                 "level", "tracker", "other"};
  return kinds;
}

const std::vector<std::string>& InstrumentUncertaintyKeys() {
  static const std::vector<std::string> keys = {"u_laser_ppm",
                                                "u_air_temperature_c",
                                                "u_air_pressure_pa",
                                                "u_air_humidity_pct",
                                                "u_material_temperature_c",
                                                "u_expansion_ppm_per_k",
                                                "u_reading_um",
                                                "u_bar_length_um",
                                                "u_bar_temperature_c",
                                                "bar_expansion_ppm_per_k",
                                                "u_ranging_um"};
  return keys;
}

Instrument ParseInstrumentBody(const json& body) {
  if (!body.is_object()) {
    RefuseField("body", "must be an object {\"instrument\", \"kind\", \"uncertainties\", …}");
  }
  for (const auto& [key, value] : body.items()) {
    if (!OneOf(BodyKeys(), key)) {
      RefuseField(key, "is not a key of an instrument (" + Joined(BodyKeys()) + ")");
    }
  }
  Instrument out;
  if (!body.contains("instrument")) RefuseField("instrument", "is required");
  out.instrument = EntryText(body["instrument"], "instrument");
  if (!body.contains("kind")) RefuseField("kind", "is required");
  if (!body["kind"].is_string() || !OneOf(InstrumentKinds(), body["kind"].get<std::string>())) {
    RefuseField("kind", "must be one of " + Joined(InstrumentKinds()));
  }
  out.kind = body["kind"].get<std::string>();
  const auto given = [&](const char* key) { return body.contains(key) && !body[key].is_null(); };
  if (given("uncertainties")) out.uncertainties = Uncertainties(body["uncertainties"]);
  if (given("calibrated")) out.calibrated = CalibratedDate(body["calibrated"]);
  if (given("calibration_interval_days")) {
    out.calibration_interval_days = IntervalDays(body["calibration_interval_days"]);
  }
  if (given("certificate")) out.certificate = EntryText(body["certificate"], "certificate");
  return out;
}

json InstrumentBodyJson(const Instrument& i) {
  json u = json::object();
  for (const auto& [k, v] : i.uncertainties) u[k] = v;
  return {{"instrument", i.instrument},
          {"kind", i.kind},
          {"uncertainties", u},
          {"calibrated", i.calibrated ? json(*i.calibrated) : json(nullptr)},
          {"calibration_interval_days",
           i.calibration_interval_days ? json(*i.calibration_interval_days) : json(nullptr)},
          {"certificate", i.certificate ? json(*i.certificate) : json(nullptr)}};
}

std::optional<std::string> CalibrationDue(const Instrument& i) {
  if (!i.calibrated || !i.calibration_interval_days) return std::nullopt;
  const auto day = ingest::IsoDateDays(*i.calibrated);
  if (!day) return std::nullopt;
  return ingest::IsoDateFromDays(*day + *i.calibration_interval_days);
}

json InstrumentJson(const Instrument& i) {
  json j = {{"serial", i.serial}, {"version", i.version}, {"created_at", i.created_at}};
  j.update(InstrumentBodyJson(i));
  const auto due = CalibrationDue(i);
  j["calibration_due"] = due ? json(*due) : json(nullptr);
  return j;
}

InstrumentUse ApplyInstrument(std::map<std::string, std::string>& metadata,
                              const std::optional<Instrument>& registered,
                              const std::optional<std::string>& measured_at,
                              double upload_epoch_s) {
  InstrumentUse use;
  static const char* const kFileKeys[] = {"instrument", "instrument_serial",
                                          "instrument_calibrated", "instrument_certificate"};
  if (std::none_of(std::begin(kFileKeys), std::end(kFileKeys),
                   [&](const char* k) { return metadata.count(k) > 0; })) {
    return use;
  }
  json sources = json::object();
  for (const auto& [key, value] : metadata) {
    if (IsUncertaintyKey(key)) sources[key] = "file";
  }
  std::optional<std::int64_t> due_day;
  if (registered) {
    for (const auto& [key, u] : registered->uncertainties) {
      if (metadata.emplace(key, NumberText(u)).second) sources[key] = "register";
    }
    metadata.emplace("instrument", registered->instrument);
    if (registered->calibrated) metadata.emplace("instrument_calibrated", *registered->calibrated);
    if (registered->certificate) {
      metadata.emplace("instrument_certificate", *registered->certificate);
    }
    const auto calibrated = metadata.find("instrument_calibrated");
    const auto day =
        calibrated == metadata.end() ? std::nullopt : ingest::IsoDateDays(calibrated->second);
    if (day && registered->calibration_interval_days) {
      due_day = *day + *registered->calibration_interval_days;
    }
  }
  std::optional<double> when;
  if (measured_at) when = ingest::Iso8601EpochSeconds(*measured_at);
  const double t = when.value_or(upload_epoch_s);
  const bool overdue = due_day && std::floor(t / 86400.0) > static_cast<double>(*due_day);
  const std::string due = due_day ? ingest::IsoDateFromDays(*due_day) : "";
  use.block = {{"instrument", TextOrNull(metadata, "instrument")},
               {"kind", registered ? json(registered->kind) : json(nullptr)},
               {"serial", TextOrNull(metadata, "instrument_serial")},
               {"calibrated", TextOrNull(metadata, "instrument_calibrated")},
               {"certificate", TextOrNull(metadata, "instrument_certificate")},
               {"register_version", registered ? json(registered->version) : json(nullptr)},
               {"sources", std::move(sources)},
               {"calibration_due", due_day ? json(due) : json(nullptr)},
               {"overdue", overdue}};
  if (overdue) {
    use.warnings.push_back("instrument " + metadata["instrument_serial"] +
                           " was past its calibration interval (due " + due +
                           ") when this was measured");
  }
  return use;
}

}  // namespace km::server
