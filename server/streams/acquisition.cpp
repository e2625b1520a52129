#include "server/streams/acquisition.h"

#include <fstream>
#include <sstream>
#include <utility>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "server/base/errors.h"
#include "server/base/net_ranges.h"

namespace km::server {

namespace mb = ingest::modbus;

struct Acquisition::Entry {
  std::string machine_id;
  mb::DeviceConfig config;
  StreamId stream_id;
  std::unique_ptr<ingest::SampleSink> sink;
  std::unique_ptr<mb::ModbusDevice> device;
};

Acquisition::Acquisition(StreamHub& hub, OpenStream open) : hub_(hub), open_(std::move(open)) {}

Acquisition::~Acquisition() {
  StopAll();
}

std::unique_ptr<Acquisition::Entry> Acquisition::Prepare(const nlohmann::json& device,
                                                         const std::string& file,
                                                         const std::string& path) {
  const std::string prefix = path.empty() ? "" : path + ".";
  if (!device.is_object()) throw InvalidInput(file, 0, path, "a device must be a JSON object");
  if (!device.contains("machine_id") || !device["machine_id"].is_string() ||
      device["machine_id"].get<std::string>().empty()) {
    throw InvalidInput(file, 0, prefix + "machine_id",
                       "the machine the device's sensors measure is required");
  }
  auto e = std::make_unique<Entry>();
  e->machine_id = device["machine_id"].get<std::string>();
  nlohmann::json rest = device;
  rest.erase("machine_id");
  e->config = mb::ParseModbusDevice(rest, file, path);
  std::lock_guard lock(mu_);
  for (const auto& other : entries_) {
    if (other->config.name == e->config.name) {
      throw InvalidInput(file, 0, prefix + "name",
                         "a device named '" + e->config.name + "' is running already");
    }
  }
  return e;
}

nlohmann::json Acquisition::StartEntry(std::unique_ptr<Entry> e) {
  nlohmann::json channels = nlohmann::json::array();
  for (const auto& c : e->config.channels) {
    channels.push_back({{"channel", c.channel},
                        {"name", c.name},
                        {"unit", "um"},
                        {"rate_hz", 1000.0 / e->config.poll_interval_ms}});
  }
  nlohmann::json request = {{"machine_id", e->machine_id},
                            {"name", e->config.name},
                            {"channels", channels},
                            {"device", mb::ToJson(e->config)}};
  e->stream_id = open_(request, "modbus:" + e->config.name);
  e->sink = hub_.SinkFor(e->stream_id);
  e->device = std::make_unique<mb::ModbusDevice>(e->config, *e->sink);
  e->device->Start();
  nlohmann::json entry = EntryJson(*e);
  std::lock_guard lock(mu_);
  entries_.push_back(std::move(e));
  return entry;
}

void Acquisition::StartFromFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidInput(path, 0, "", "cannot read the Modbus device configuration");
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  const nlohmann::json j = ingest::ParseJsonText(text, path);
  if (!j.is_object() || !j.contains("devices") || !j["devices"].is_array()) {
    throw InvalidInput(path, 0, "devices", "an object {\"devices\": [...]} is required");
  }
  for (const auto& [key, v] : j.items()) {
    if (key != "devices") throw InvalidInput(path, 0, key, "unknown key");
  }
  // Validate everything first: a bad entry starts nothing.
  std::vector<std::unique_ptr<Entry>> prepared;
  for (std::size_t i = 0; i < j["devices"].size(); ++i) {
    const std::string at = "devices[" + std::to_string(i) + "]";
    auto e = Prepare(j["devices"][i], path, at);
    for (const auto& p : prepared) {
      if (p->config.name == e->config.name) {
        throw InvalidInput(path, 0, at + ".name", "device name '" + e->config.name + "' repeats");
      }
    }
    prepared.push_back(std::move(e));
  }
  for (auto& e : prepared) StartEntry(std::move(e));
}

void Acquisition::SetLimits(const DeviceLimits& limits) {
  for (const auto& n : limits.networks) {
    if (!ParseNetwork(n)) {
      throw InvalidInput("", 0, "device_networks", "'" + n + "' is not an address range (CIDR)");
    }
  }
  std::lock_guard lock(mu_);
  max_devices_ = limits.max_devices;
  networks_ = limits.networks;
}

nlohmann::json Acquisition::Add(const nlohmann::json& device, const std::string& file) {
  auto e = Prepare(device, file, "");
  const auto addr = ParseIpAddress(e->config.host);
  if (!addr) {
    throw InvalidInput(file, 0, "host",
                       "'" + e->config.host +
                           "' is not a numeric IPv4 or IPv6 address (nor localhost): devices "
                           "added through the API name their host by address");
  }
  {
    std::lock_guard lock(mu_);
    bool allowed = false;
    std::string list;
    for (const auto& text : networks_) {
      const auto net = ParseNetwork(text);
      allowed = allowed || (net && NetworkContains(*net, *addr));
      list += (list.empty() ? "" : ", ") + text;
    }
    if (!allowed) {
      throw Forbidden("the device host " + e->config.host +
                      " is outside the networks devices may poll (device_networks: " +
                      (list.empty() ? std::string("none") : list) + ")");
    }
    if (entries_.size() + starting_ >= max_devices_) {
      throw Forbidden("at most " + std::to_string(max_devices_) +
                      " devices may run at once (max_devices); stop one first");
    }
    ++starting_;
  }
  try {
    auto out = StartEntry(std::move(e));
    std::lock_guard lock(mu_);
    --starting_;
    return out;
  } catch (...) {
    std::lock_guard lock(mu_);
    --starting_;
    throw;
  }
}

void Acquisition::Remove(const std::string& name) {
  std::unique_ptr<Entry> gone;
  {
    std::lock_guard lock(mu_);
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if ((*it)->config.name == name) {
        gone = std::move(*it);
        entries_.erase(it);
        break;
      }
    }
  }
  if (!gone) throw NotFound("no device named '" + name + "'");
  gone->device->Stop();
  hub_.Flush(gone->stream_id);
}

nlohmann::json Acquisition::EntryJson(const Entry& e) const {
  return {{"name", e.config.name},
          {"machine_id", e.machine_id},
          {"stream_id", e.stream_id},
          {"config", mb::ToJson(e.config)},
          {"status", mb::ToJson(e.device->Status())}};
}

nlohmann::json Acquisition::Devices() const {
  std::lock_guard lock(mu_);
  nlohmann::json out = nlohmann::json::array();
  for (const auto& e : entries_) out.push_back(EntryJson(*e));
  return out;
}

void Acquisition::StopAll() {
  std::vector<std::unique_ptr<Entry>> all;
  {
    std::lock_guard lock(mu_);
    all.swap(entries_);
  }
  for (auto& e : all) e->device->Stop();
}

}  // namespace km::server
