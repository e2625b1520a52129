// Device configuration parsing: defaults, round trip, and errors naming the JSON path.
#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "ingest/modbus/modbus_config.h"

namespace km::ingest::modbus {
namespace {

using nlohmann::json;

json MinimalDevice() {
  return {{"name", "cap-x"},
          {"host", "127.0.0.1"},
          {"poll_interval_ms", 10},
          {"channels", {{{"channel", 1}, {"address", 0}, {"type", "float32"}}}}};
}

// The InvalidInput thrown for `doc`, or fails.
InvalidInput ErrorOf(const std::string& text) {
  try {
    ParseModbusConfig(text, "devices.json");
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "devices.json");
    return e;
  }
  ADD_FAILURE() << "no error for " << text;
  return InvalidInput("none");
}

InvalidInput ErrorOfDevice(const json& device) {
  return ErrorOf(json{{"devices", {device}}}.dump());
}

TEST(ModbusConfig, DefaultsAndFullExample) {
  const std::string text = R"({"devices":[
    {"name":"cap-x","host":"127.0.0.1","port":1502,"unit_id":3,
     "poll_interval_ms":10,"response_timeout_ms":150,"address_base":1,"table":"input",
     "reconnect":{"initial_ms":20,"max_ms":400},
     "channels":[{"channel":1,"name":"gap_x","address":1,"type":"float32",
                  "byte_order":"little","word_order":"little","scale":2.5,"offset":-1.0},
                 {"channel":7,"address":3,"type":"int16"}]},
    {"name":"cap-y","host":"sensor.local","poll_interval_ms":5,
     "channels":[{"channel":1,"address":0,"type":"uint32"}]}]})";
  const auto devs = ParseModbusConfig(text, "devices.json");
  ASSERT_EQ(devs.size(), 2u);
  const DeviceConfig& x = devs[0];
  EXPECT_EQ(x.port, 1502);
  EXPECT_EQ(x.unit_id, 3);
  EXPECT_EQ(x.response_timeout_ms, 150);
  EXPECT_EQ(x.address_base, 1);
  EXPECT_EQ(x.table, RegisterTable::kInput);
  EXPECT_EQ(x.reconnect.initial_ms, 20);
  EXPECT_EQ(x.reconnect.max_ms, 400);
  ASSERT_EQ(x.channels.size(), 2u);
  EXPECT_EQ(x.channels[0].type, RegisterType::kFloat32);
  EXPECT_EQ(x.channels[0].byte_order, ByteOrder::kLittle);
  EXPECT_EQ(x.channels[0].word_order, WordOrder::kLittle);
  EXPECT_EQ(x.channels[0].scale, 2.5);
  EXPECT_EQ(x.channels[0].offset, -1.0);
  EXPECT_EQ(WireAddress(x, x.channels[0]), 0u);
  EXPECT_EQ(WireAddress(x, x.channels[1]), 2u);
  EXPECT_EQ(x.channels[1].name, "channel7");
  const DeviceConfig& y = devs[1];  // defaults
  EXPECT_EQ(y.port, 502);
  EXPECT_EQ(y.unit_id, 1);
  EXPECT_EQ(y.address_base, 0);
  EXPECT_EQ(y.table, RegisterTable::kHolding);
  EXPECT_EQ(y.response_timeout_ms, 200);
  EXPECT_EQ(y.reconnect.initial_ms, 100);
  EXPECT_EQ(y.reconnect.max_ms, 5000);
  EXPECT_EQ(y.channels[0].byte_order, ByteOrder::kBig);
  EXPECT_EQ(y.channels[0].word_order, WordOrder::kBig);
  EXPECT_EQ(y.channels[0].scale, 1.0);
  EXPECT_EQ(y.channels[0].offset, 0.0);

  // ToJson round trip.
  for (const DeviceConfig& d : devs) {
    const json j = ToJson(d);
    const DeviceConfig back = ParseModbusDevice(j, "rt", "");
    EXPECT_EQ(ToJson(back), j);
  }
  const auto blocks = PlanDeviceBlocks(x);
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].start, 0u);
  EXPECT_EQ(blocks[0].count, 3);
}

TEST(ModbusConfig, ErrorsNameTheJsonPath) {
  struct Case {
    std::function<void(json&)> edit;
    std::string field;
    std::string reason_part;
  };
  const std::vector<Case> cases = {
      {[](json& d) { d["channels"][0]["type"] = "float64"; }, "devices[0].channels[0].type",
       "unknown type"},
      {[](json& d) { d["channels"][0]["byte_order"] = "middle"; },
       "devices[0].channels[0].byte_order", "unknown byte order"},
      {[](json& d) { d["channels"][0]["word_order"] = 1; }, "devices[0].channels[0].word_order",
       "must be a string"},
      {[](json& d) { d["poll_interval_ms"] = 0; }, "devices[0].poll_interval_ms", "1..3600000"},
      {[](json& d) { d.erase("poll_interval_ms"); }, "devices[0].poll_interval_ms", "missing"},
      {[](json& d) { d["poll_interval_ms"] = 2.5; }, "devices[0].poll_interval_ms", "integer"},
      {[](json& d) { d["port"] = 70000; }, "devices[0].port", "1..65535"},
      {[](json& d) { d["unit_id"] = 250; }, "devices[0].unit_id", "0..247 or 255"},
      {[](json& d) { d["address_base"] = 2; }, "devices[0].address_base", "0..1"},
      {[](json& d) { d["table"] = "coils"; }, "devices[0].table", "unknown table"},
      {[](json& d) {
         d["reconnect"] = {{"initial_ms", 500}, {"max_ms", 100}};
       },
       "devices[0].reconnect.max_ms", ">= initial_ms"},
      {[](json& d) { d["name"] = "bad name"; }, "devices[0].name", "characters"},
      {[](json& d) { d.erase("host"); }, "devices[0].host", "missing"},
      {[](json& d) { d["colour"] = "red"; }, "devices[0].colour", "unknown key"},
      {[](json& d) { d["channels"] = json::array(); }, "devices[0].channels", "non-empty"},
      {[](json& d) { d["channels"][0]["address"] = 65535; }, "devices[0].channels[0].address",
       "0..65534"},
      {[](json& d) { d["channels"][0]["address"] = -1; }, "devices[0].channels[0].address",
       "0..65534"},
      {[](json& d) {
         d["address_base"] = 1;
         d["channels"][0]["address"] = 0;
       },
       "devices[0].channels[0].address", "1..65535"},
      {[](json& d) { d["channels"][0]["scale"] = 0; }, "devices[0].channels[0].scale", "zero"},
      {[](json& d) { d["channels"][0]["offset"] = "1"; }, "devices[0].channels[0].offset",
       "number"},
      {[](json& d) { d["channels"][0].erase("channel"); }, "devices[0].channels[0].channel",
       "missing"},
      {[](json& d) {
         d["channels"].push_back({{"channel", 1}, {"address", 10}, {"type", "int16"}});
       },
       "devices[0].channels[1].channel", "duplicate channel id 1"},
      {[](json& d) {
         d["channels"].push_back({{"channel", 2}, {"address", 1}, {"type", "int16"}});
       },
       "devices[0].channels[1].address", "overlap"},
      {[](json& d) {
         d["channels"].push_back({{"channel", 2}, {"address", 2}, {"type", "int16"}});
         d["channels"].push_back({{"channel", 3}, {"address", 3}, {"type", "int32"}});
         d["channels"].push_back({{"channel", 4}, {"address", 4}, {"type", "uint16"}});
       },
       "devices[0].channels[3].address", "devices[0].channels[2]"},
  };
  for (const Case& c : cases) {
    json d = MinimalDevice();
    c.edit(d);
    const InvalidInput e = ErrorOfDevice(d);
    EXPECT_EQ(e.field(), c.field) << d.dump();
    EXPECT_NE(e.reason().find(c.reason_part), std::string::npos)
        << "reason '" << e.reason() << "' lacks '" << c.reason_part << "'";
    EXPECT_EQ(e.line(), 0u);
  }
}

TEST(ModbusConfig, NonFiniteScaleIsRefused) {
  // JSON text has no NaN/Inf; a number overflowing a double is refused by the reader, and a
  // device object built in code (e.g. by the API) holding NaN/Inf is refused by the field check.
  const InvalidInput e =
      ErrorOf(R"({"devices":[{"name":"a","host":"h","poll_interval_ms":1,"channels":[{"channel":1,)"
              R"("address":0,"type":"int16","scale":1e999}]}]})");
  EXPECT_NE(e.reason().find("does not fit a double"), std::string::npos) << e.reason();
  EXPECT_EQ(e.field(), "devices[0].channels[0].scale");
  for (double bad :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    for (const char* key : {"scale", "offset"}) {
      json d = MinimalDevice();
      d["channels"][0][key] = bad;
      try {
        ParseModbusDevice(d, "api", "device");
        ADD_FAILURE() << "accepted " << key << " = " << bad;
      } catch (const InvalidInput& err) {
        EXPECT_EQ(err.field(), std::string("device.channels[0].") + key);
        EXPECT_NE(err.reason().find("finite"), std::string::npos) << err.reason();
      }
    }
  }
}

TEST(ModbusConfig, DocumentLevelErrors) {
  json two = {{"devices", {MinimalDevice(), MinimalDevice()}}};
  InvalidInput e = ErrorOf(two.dump());
  EXPECT_EQ(e.field(), "devices[1].name");
  EXPECT_NE(e.reason().find("duplicate device name 'cap-x'"), std::string::npos);

  e = ErrorOf("[]");
  EXPECT_EQ(e.field(), "");
  e = ErrorOf("{}");
  EXPECT_EQ(e.field(), "devices");
  e = ErrorOf(R"({"devices":{}})");
  EXPECT_EQ(e.field(), "devices");
  e = ErrorOf(R"({"devices":[3]})");
  EXPECT_EQ(e.field(), "devices[0]");
  EXPECT_TRUE(ParseModbusConfig(R"({"devices":[]})", "f").empty());
}

TEST(ModbusConfig, SyntaxErrorNamesTheLine) {
  const InvalidInput e = ErrorOf("{\n  \"devices\": [\n    {\"name\": \"a\",,}\n  ]\n}\n");
  EXPECT_EQ(e.line(), 3u);
  EXPECT_NE(e.reason().find("not valid JSON"), std::string::npos);
  const InvalidInput first = ErrorOf("nope");
  EXPECT_EQ(first.line(), 1u);
}

TEST(ModbusConfig, DeviceObjectWithoutPathPrefix) {
  json d = MinimalDevice();
  d["channels"][0]["type"] = "x";
  try {
    ParseModbusDevice(d, "POST /api/modbus/devices", "");
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "channels[0].type");
    EXPECT_EQ(e.file(), "POST /api/modbus/devices");
  }
}

}  // namespace
}  // namespace km::ingest::modbus
