#include "server/instruments/instrument_service.h"

#include <chrono>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "ingest/text_format.h"
#include "server/base/sha256.h"

namespace km::server {
namespace {

void CheckSerial(const std::string& serial) {
  if (const auto why = ingest::InstrumentSerialProblem(serial)) {
    throw InvalidInput("", 0, "serial", ingest::Quote(serial) + " " + *why);
  }
}

// A stored version, parsed again as it was validated when stored.
Instrument InstrumentOf(const InstrumentVersionRecord& r) {
  Instrument i = ParseInstrumentBody(ingest::ParseJsonText(r.instrument_json, "stored instrument"));
  i.serial = r.serial;
  i.version = r.version;
  i.created_at = r.created_at;
  return i;
}

double NowEpochSeconds() {
  using namespace std::chrono;
  return duration<double>(system_clock::now().time_since_epoch()).count();
}

}  // namespace

nlohmann::json InstrumentService::Put(const std::string& serial, const nlohmann::json& body) {
  CheckSerial(serial);
  const Instrument entry = ParseInstrumentBody(body);
  NewInstrumentVersion v;
  v.serial = serial;
  v.instrument_json = InstrumentBodyJson(entry).dump();
  v.sha256 = Sha256Hex(v.instrument_json);
  const auto put = store_.PutInstrument(v);
  nlohmann::json out = InstrumentJson(InstrumentOf(put.record));
  out["created"] = put.created;
  return out;
}

nlohmann::json InstrumentService::Get(const std::string& serial,
                                      std::optional<std::int64_t> version) {
  CheckSerial(serial);
  if (const auto r = store_.GetInstrument(serial, version)) return InstrumentJson(InstrumentOf(*r));
  if (!version) throw NotFound("instrument '" + serial + "' is not registered");
  const auto newest = store_.GetInstrument(serial, std::nullopt);
  throw NotFound("instrument '" + serial + "' has no version " + std::to_string(*version) +
                 (newest ? "; the newest is version " + std::to_string(newest->version)
                         : "; it is not registered"));
}

nlohmann::json InstrumentService::List() {
  nlohmann::json items = nlohmann::json::array();
  for (const auto& r : store_.ListInstruments()) items.push_back(InstrumentJson(InstrumentOf(r)));
  const auto total = items.size();
  return {{"items", std::move(items)}, {"total", total}};
}

std::optional<Instrument> InstrumentService::Find(const std::string& serial) {
  if (ingest::InstrumentSerialProblem(serial)) return std::nullopt;
  const auto r = store_.GetInstrument(serial, std::nullopt);
  if (!r) return std::nullopt;
  return InstrumentOf(*r);
}

InstrumentHook InstrumentService::Hook() {
  InstrumentService* self = this;
  return [self](std::map<std::string, std::string>& metadata,
                const std::optional<std::string>& measured_at) {
    std::optional<Instrument> registered;
    if (const auto s = metadata.find("instrument_serial"); s != metadata.end()) {
      registered = self->Find(s->second);
    }
    return ApplyInstrument(metadata, registered, measured_at, NowEpochSeconds());
  };
}

}  // namespace km::server
