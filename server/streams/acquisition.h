// Modbus TCP acquisition in the server: the configured devices, each polled by its own thread
// (ingest/modbus/modbus_device.h) into its own stream (server/streams/streams.h).
//
// A device entry is the ingest device object (docs/modbus.md) plus the server's key
// "machine_id" (the machine the sensors measure). Each time a device starts — at server start
// from the `modbus_config` file, or when added through the API — a new stream is opened for
// it (source "modbus:<name>"), since the device's sample counters start at 0 with every
// acquisition run. Devices added through the API run until the server stops; devices that
// must come back after a restart belong in the config file.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ingest/modbus/modbus_device.h"
#include "server/streams/streams.h"

namespace km::server {

// Opens a stream for a device: the stream request (docs/streams.md) and its source; returns
// the stream id (StreamService::CreateStream).
using OpenStream =
    std::function<StreamId(const nlohmann::json& request, const std::string& source)>;

// What devices added through the API may be: at most max_devices running at once (those of
// the config file included), each polling a host (a numeric address) within one of the
// networks (CIDR). Devices of the config file are the operator's own and are not checked.
struct DeviceLimits {
  std::size_t max_devices = 16;
  std::vector<std::string> networks = {"127.0.0.0/8", "::1/128"};
};

class Acquisition {
 public:
  // The devices' samples go to `hub`, each run into a stream opened with `open`.
  Acquisition(StreamHub& hub, OpenStream open);
  ~Acquisition();  // stops every device
  Acquisition(const Acquisition&) = delete;
  Acquisition& operator=(const Acquisition&) = delete;

  // Loads {"devices": [...]} from a file and starts every device (InvalidInput naming the file
  // and JSON path of a bad field; nothing is started then).
  void StartFromFile(const std::string& path);
  // One device object (with machine_id); starts it and returns its entry (Devices() item).
  // Refused: InvalidInput (400) when the host is not a numeric address, Forbidden (403) when
  // it is outside the allowed networks or max_devices run already.
  nlohmann::json Add(const nlohmann::json& device, const std::string& file = "request");
  // InvalidInput naming a malformed network.
  void SetLimits(const DeviceLimits& limits);
  // Stops a device; its stream and samples stay. NotFound for an unknown name.
  void Remove(const std::string& name);
  // [{name, machine_id, stream_id, config, status}] in the order added.
  nlohmann::json Devices() const;
  void StopAll();

 private:
  struct Entry;
  std::unique_ptr<Entry> Prepare(const nlohmann::json& device, const std::string& file,
                                 const std::string& path);
  nlohmann::json StartEntry(std::unique_ptr<Entry> e);  // its Devices() item
  nlohmann::json EntryJson(const Entry& e) const;

  StreamHub& hub_;
  OpenStream open_;
  mutable std::mutex mu_;
  std::vector<std::unique_ptr<Entry>> entries_;
  std::size_t max_devices_ = DeviceLimits{}.max_devices;
  std::vector<std::string> networks_ = DeviceLimits{}.networks;
  std::size_t starting_ = 0;  // added through the API, being started
};

}  // namespace km::server
