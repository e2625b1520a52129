#include "ingest/modbus/modbus_config.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"

namespace km::ingest::modbus {

namespace {

using nlohmann::json;

std::string Join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

void RejectUnknownKeys(const json& j, std::initializer_list<const char*> known,
                       const std::string& file, const std::string& path) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const bool ok =
        std::any_of(known.begin(), known.end(), [&](const char* k) { return it.key() == k; });
    if (!ok) throw InvalidInput(file, 0, Join(path, it.key()), "unknown key");
  }
}

std::int64_t Integer(const json& j, const char* key, std::int64_t lo, std::int64_t hi,
                     const std::string& file, const std::string& path) {
  const json& v = j.at(key);
  const std::string field = Join(path, key);
  std::int64_t x = 0;
  if (v.is_number_integer()) {
    if (v.is_number_unsigned() &&
        v.get<std::uint64_t>() >
            static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
      throw InvalidInput(file, 0, field, "out of range");
    x = v.get<std::int64_t>();
  } else if (v.is_number_float()) {
    const double d = v.get<double>();
    if (!std::isfinite(d) || d != std::floor(d) || std::fabs(d) > 9.0e15)
      throw InvalidInput(file, 0, field, "must be an integer");
    x = static_cast<std::int64_t>(d);
  } else {
    throw InvalidInput(file, 0, field, "must be an integer");
  }
  if (x < lo || x > hi) {
    throw InvalidInput(file, 0, field,
                       "must be in " + std::to_string(lo) + ".." + std::to_string(hi) + " (got " +
                           std::to_string(x) + ")");
  }
  return x;
}

std::int64_t OptInteger(const json& j, const char* key, std::int64_t def, std::int64_t lo,
                        std::int64_t hi, const std::string& file, const std::string& path) {
  return j.contains(key) ? Integer(j, key, lo, hi, file, path) : def;
}

double OptFinite(const json& j, const char* key, double def, const std::string& file,
                 const std::string& path) {
  if (!j.contains(key)) return def;
  const json& v = j.at(key);
  if (!v.is_number()) throw InvalidInput(file, 0, Join(path, key), "must be a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw InvalidInput(file, 0, Join(path, key), "must be finite");
  return d;
}

std::string String(const json& j, const char* key, const std::string& file,
                   const std::string& path) {
  if (!j.contains(key)) throw InvalidInput(file, 0, Join(path, key), "missing");
  const json& v = j.at(key);
  if (!v.is_string()) throw InvalidInput(file, 0, Join(path, key), "must be a string");
  return v.get<std::string>();
}

std::string OptString(const json& j, const char* key, const std::string& def,
                      const std::string& file, const std::string& path) {
  return j.contains(key) ? String(j, key, file, path) : def;
}

bool ValidName(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

ChannelConfig ParseChannel(const json& j, const DeviceConfig& d, const std::string& file,
                           const std::string& path) {
  if (!j.is_object()) throw InvalidInput(file, 0, path, "must be an object");
  RejectUnknownKeys(
      j, {"channel", "name", "address", "type", "byte_order", "word_order", "scale", "offset"},
      file, path);
  ChannelConfig c;
  if (!j.contains("channel")) throw InvalidInput(file, 0, Join(path, "channel"), "missing");
  c.channel = static_cast<std::uint32_t>(
      Integer(j, "channel", 0, std::numeric_limits<std::uint32_t>::max(), file, path));
  c.name = OptString(j, "name", "channel" + std::to_string(c.channel), file, path);
  if (c.name.empty()) throw InvalidInput(file, 0, Join(path, "name"), "must not be empty");
  const std::string type = String(j, "type", file, path);
  if (!ParseRegisterType(type, &c.type)) {
    throw InvalidInput(
        file, 0, Join(path, "type"),
        "unknown type '" + type + "' (expected int16, uint16, int32, uint32 or float32)");
  }
  const std::string bo = OptString(j, "byte_order", "big", file, path);
  if (!ParseByteOrder(bo, &c.byte_order)) {
    throw InvalidInput(file, 0, Join(path, "byte_order"),
                       "unknown byte order '" + bo + "' (expected big or little)");
  }
  const std::string wo = OptString(j, "word_order", "big", file, path);
  if (!ParseWordOrder(wo, &c.word_order)) {
    throw InvalidInput(file, 0, Join(path, "word_order"),
                       "unknown word order '" + wo + "' (expected big or little)");
  }
  if (!j.contains("address")) throw InvalidInput(file, 0, Join(path, "address"), "missing");
  const std::int64_t lo = d.address_base;
  const std::int64_t hi = 65535 + d.address_base - (RegisterCount(c.type) - 1);
  c.address = static_cast<std::uint32_t>(Integer(j, "address", lo, hi, file, path));
  c.scale = OptFinite(j, "scale", 1.0, file, path);
  if (c.scale == 0.0) throw InvalidInput(file, 0, Join(path, "scale"), "must not be zero");
  c.offset = OptFinite(j, "offset", 0.0, file, path);
  return c;
}

}  // namespace

std::vector<ReadBlock> PlanDeviceBlocks(const DeviceConfig& d) {
  std::vector<RegisterSpan> spans;
  spans.reserve(d.channels.size());
  for (const ChannelConfig& c : d.channels) {
    spans.push_back(RegisterSpan{WireAddress(d, c), RegisterCount(c.type)});
  }
  return PlanBlocks(spans);
}

DeviceConfig ParseModbusDevice(const json& j, const std::string& file, const std::string& path) {
  if (!j.is_object()) throw InvalidInput(file, 0, path, "a device must be a JSON object");
  RejectUnknownKeys(j,
                    {"name", "host", "port", "unit_id", "poll_interval_ms", "response_timeout_ms",
                     "address_base", "table", "reconnect", "channels"},
                    file, path);
  DeviceConfig d;
  d.name = String(j, "name", file, path);
  if (!ValidName(d.name)) {
    throw InvalidInput(file, 0, Join(path, "name"), "must be 1-64 characters of A-Z a-z 0-9 _ - .");
  }
  d.host = String(j, "host", file, path);
  if (d.host.empty() || d.host.size() > 253 ||
      d.host.find_first_of(" \t\r\n/") != std::string::npos) {
    throw InvalidInput(file, 0, Join(path, "host"), "must be a host name or IP address");
  }
  d.port = static_cast<int>(OptInteger(j, "port", 502, 1, 65535, file, path));
  // libmodbus TCP accepts unit ids 0..247 and 255 (MODBUS_TCP_SLAVE).
  d.unit_id = static_cast<int>(OptInteger(j, "unit_id", 1, 0, 255, file, path));
  if (d.unit_id > 247 && d.unit_id != 255) {
    throw InvalidInput(file, 0, Join(path, "unit_id"), "must be 0..247 or 255");
  }
  if (!j.contains("poll_interval_ms")) {
    throw InvalidInput(file, 0, Join(path, "poll_interval_ms"), "missing");
  }
  d.poll_interval_ms = static_cast<int>(Integer(j, "poll_interval_ms", 1, 3'600'000, file, path));
  d.response_timeout_ms =
      static_cast<int>(OptInteger(j, "response_timeout_ms", 200, 1, 60'000, file, path));
  d.address_base = static_cast<int>(OptInteger(j, "address_base", 0, 0, 1, file, path));
  const std::string table = OptString(j, "table", "holding", file, path);
  if (table == "holding")
    d.table = RegisterTable::kHolding;
  else if (table == "input")
    d.table = RegisterTable::kInput;
  else {
    throw InvalidInput(file, 0, Join(path, "table"),
                       "unknown table '" + table + "' (expected holding or input)");
  }
  if (j.contains("reconnect")) {
    const json& r = j.at("reconnect");
    const std::string rp = Join(path, "reconnect");
    if (!r.is_object()) throw InvalidInput(file, 0, rp, "must be an object");
    RejectUnknownKeys(r, {"initial_ms", "max_ms"}, file, rp);
    d.reconnect.initial_ms =
        static_cast<int>(OptInteger(r, "initial_ms", 100, 1, 3'600'000, file, rp));
    d.reconnect.max_ms = static_cast<int>(OptInteger(r, "max_ms", 5000, 1, 3'600'000, file, rp));
    if (d.reconnect.max_ms < d.reconnect.initial_ms) {
      throw InvalidInput(file, 0, Join(rp, "max_ms"), "must be >= initial_ms");
    }
  }
  const std::string cp = Join(path, "channels");
  if (!j.contains("channels")) throw InvalidInput(file, 0, cp, "missing");
  const json& chans = j.at("channels");
  if (!chans.is_array() || chans.empty()) {
    throw InvalidInput(file, 0, cp, "must be a non-empty array");
  }
  std::set<std::uint32_t> ids;
  std::set<std::string> names;
  for (std::size_t i = 0; i < chans.size(); ++i) {
    const std::string p = cp + "[" + std::to_string(i) + "]";
    ChannelConfig c = ParseChannel(chans[i], d, file, p);
    if (!ids.insert(c.channel).second) {
      throw InvalidInput(file, 0, Join(p, "channel"),
                         "duplicate channel id " + std::to_string(c.channel));
    }
    if (!names.insert(c.name).second) {
      throw InvalidInput(file, 0, Join(p, "name"), "duplicate channel name '" + c.name + "'");
    }
    // Overlap with an earlier channel of this device.
    const std::uint32_t a0 = WireAddress(d, c);
    const std::uint32_t a1 = a0 + static_cast<std::uint32_t>(RegisterCount(c.type));
    for (std::size_t k = 0; k < d.channels.size(); ++k) {
      const ChannelConfig& o = d.channels[k];
      const std::uint32_t b0 = WireAddress(d, o);
      const std::uint32_t b1 = b0 + static_cast<std::uint32_t>(RegisterCount(o.type));
      if (a0 < b1 && b0 < a1) {
        throw InvalidInput(
            file, 0, Join(p, "address"),
            "registers overlap those of " + cp + "[" + std::to_string(k) + "] ('" + o.name + "')");
      }
    }
    d.channels.push_back(std::move(c));
  }
  return d;
}

std::vector<DeviceConfig> ParseModbusConfig(std::string_view json_text, const std::string& file) {
  const json doc = ingest::ParseJsonText(json_text, file);
  if (!doc.is_object()) throw InvalidInput(file, 0, "", "must be a JSON object with \"devices\"");
  RejectUnknownKeys(doc, {"devices"}, file, "");
  if (!doc.contains("devices")) throw InvalidInput(file, 0, "devices", "missing");
  const json& devs = doc.at("devices");
  if (!devs.is_array()) throw InvalidInput(file, 0, "devices", "must be an array");
  std::vector<DeviceConfig> out;
  std::set<std::string> names;
  for (std::size_t i = 0; i < devs.size(); ++i) {
    const std::string p = "devices[" + std::to_string(i) + "]";
    DeviceConfig d = ParseModbusDevice(devs[i], file, p);
    if (!names.insert(d.name).second) {
      throw InvalidInput(file, 0, p + ".name", "duplicate device name '" + d.name + "'");
    }
    out.push_back(std::move(d));
  }
  return out;
}

json ToJson(const DeviceConfig& d) {
  json chans = json::array();
  for (const ChannelConfig& c : d.channels) {
    chans.push_back({{"channel", c.channel},
                     {"name", c.name},
                     {"address", c.address},
                     {"type", std::string(ToString(c.type))},
                     {"byte_order", std::string(ToString(c.byte_order))},
                     {"word_order", std::string(ToString(c.word_order))},
                     {"scale", c.scale},
                     {"offset", c.offset}});
  }
  return {{"name", d.name},
          {"host", d.host},
          {"port", d.port},
          {"unit_id", d.unit_id},
          {"poll_interval_ms", d.poll_interval_ms},
          {"response_timeout_ms", d.response_timeout_ms},
          {"address_base", d.address_base},
          {"table", d.table == RegisterTable::kHolding ? "holding" : "input"},
          {"reconnect", {{"initial_ms", d.reconnect.initial_ms}, {"max_ms", d.reconnect.max_ms}}},
          {"channels", chans}};
}

}  // namespace km::ingest::modbus
