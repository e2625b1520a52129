// Modbus TCP device configuration (docs/modbus.md): a JSON document
//   {"devices":[{"name":"cap-x","host":"127.0.0.1","port":1502,"unit_id":1,
//                "poll_interval_ms":10,"response_timeout_ms":200,"address_base":0,
//                "table":"holding","reconnect":{"initial_ms":100,"max_ms":5000},
//                "channels":[{"channel":1,"name":"gap_x","address":0,"type":"float32",
//                             "byte_order":"big","word_order":"big","scale":1.0,"offset":0.0}]}]}
// Each channel's reading is value_um = raw · scale + offset (ingest/modbus/modbus_decode.h).
// Every error is a km::InvalidInput naming the file and the JSON path of the field
// ("devices[0].channels[1].type"); JSON syntax errors name the line.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "ingest/modbus/modbus_decode.h"

namespace km::ingest::modbus {

enum class RegisterTable { kHolding, kInput };  // FC3 / FC4

struct ChannelConfig {
  std::uint32_t channel = 0;  // StreamSample::channel, unique within the device
  std::string name;
  std::uint32_t address = 0;  // as configured (address_base applies)
  RegisterType type = RegisterType::kUint16;
  ByteOrder byte_order = ByteOrder::kBig;
  WordOrder word_order = WordOrder::kBig;
  double scale = 1.0;
  double offset = 0.0;
};

struct ReconnectConfig {
  int initial_ms = 100;  // first backoff delay after a failed connect; doubles each failure
  int max_ms = 5000;     // cap of the backoff delay
};

struct DeviceConfig {
  std::string name;
  std::string host;
  int port = 502;
  int unit_id = 1;
  int poll_interval_ms = 0;  // required
  int response_timeout_ms = 200;
  int address_base = 0;  // 0: addresses are wire addresses; 1: address 1 is wire address 0
  RegisterTable table = RegisterTable::kHolding;
  ReconnectConfig reconnect;
  std::vector<ChannelConfig> channels;
};

// Wire (0-based) address of a channel's first register.
inline std::uint32_t WireAddress(const DeviceConfig& d, const ChannelConfig& c) {
  return c.address - static_cast<std::uint32_t>(d.address_base);
}

// The device's read plan (PlanBlocks over its channels; members index d.channels).
std::vector<ReadBlock> PlanDeviceBlocks(const DeviceConfig& d);

// Parses {"devices":[...]}. Refuses duplicate device names. Throws km::InvalidInput.
std::vector<DeviceConfig> ParseModbusConfig(std::string_view json_text, const std::string& file);

// Parses and validates one device object; `path` prefixes field names ("devices[0]"; may be
// empty, then fields are named "channels[1].type").
DeviceConfig ParseModbusDevice(const nlohmann::json& j, const std::string& file,
                               const std::string& path);

// The device as a JSON object with every field (ParseModbusDevice(ToJson(d)) == d).
nlohmann::json ToJson(const DeviceConfig& d);

}  // namespace km::ingest::modbus
