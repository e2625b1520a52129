// Modbus TCP device configuration (ingest/modbus/modbus_config.h): every accepted device has a read
// plan, and its JSON form parses back to the same device.
#include "ingest/modbus/modbus_config.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

bool SameChannel(const km::ingest::modbus::ChannelConfig& a,
                 const km::ingest::modbus::ChannelConfig& b) {
  return a.channel == b.channel && a.name == b.name && a.address == b.address && a.type == b.type &&
         a.byte_order == b.byte_order && a.word_order == b.word_order && a.scale == b.scale &&
         a.offset == b.offset;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace mb = km::ingest::modbus;
  km::fuzz::Guarded([&] {
    const auto devices = mb::ParseModbusConfig(km::fuzz::AsText(data, size), "fuzz.json");
    for (const auto& d : devices) {
      mb::PlanDeviceBlocks(d);
      const auto again = mb::ParseModbusDevice(mb::ToJson(d), "fuzz-rewritten.json", "");
      km::fuzz::Check(again.name == d.name && again.host == d.host && again.port == d.port &&
                          again.unit_id == d.unit_id &&
                          again.poll_interval_ms == d.poll_interval_ms &&
                          again.response_timeout_ms == d.response_timeout_ms &&
                          again.address_base == d.address_base && again.table == d.table &&
                          again.reconnect.initial_ms == d.reconnect.initial_ms &&
                          again.reconnect.max_ms == d.reconnect.max_ms &&
                          again.channels.size() == d.channels.size(),
                      "a device survives ToJson and parsing");
      for (std::size_t i = 0; i < d.channels.size(); ++i) {
        km::fuzz::Check(SameChannel(again.channels[i], d.channels[i]),
                        "a channel survives ToJson and parsing");
      }
    }
  });
  return 0;
}
