// Modbus TCP acquisition inside a real kinemetricd against a real Modbus TCP server (the
// libmodbus test server): a device from the config file is polled into its own stream, its
// status is visible in the API; the Modbus server is killed and restarted — acquisition resumes
// by itself, the outage is one recorded gap and every other tick is stored; a device added
// through the API that cannot connect is counted, not fatal, and does not stall the first; the
// devices' figures are in /metrics.
#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "tests/integration/modbus/modbus_process.h"
#include "tests/integration/server/server_process.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

constexpr const char* kToken = "acquisition-test-token";

class Api {
 public:
  explicit Api(int port) : c_("127.0.0.1", port) {
    c_.set_read_timeout(10, 0);
    c_.set_default_headers({{"Authorization", std::string("Bearer ") + kToken}});
  }
  json Get(const std::string& p) {
    auto r = c_.Get(p.c_str());
    if (!r || r->status != 200) {
      ADD_FAILURE() << p << ": " << (r ? r->body : "no answer");
      return json::object();
    }
    return json::parse(r->body);
  }
  httplib::Result Post(const std::string& p, const json& body) {
    return c_.Post(p.c_str(), body.dump(), "application/json");
  }
  httplib::Result Delete(const std::string& p) { return c_.Delete(p.c_str()); }
  std::string Text(const std::string& p) {
    auto r = c_.Get(p.c_str());
    return r && r->status == 200 ? r->body : std::string();
  }

 private:
  httplib::Client c_;
};

// The value of one series of a /metrics exposition (NaN when absent).
double MetricValue(const std::string& text, const std::string& series) {
  const auto at = text.find("\n" + series + " ");
  if (at == std::string::npos) return std::nan("");
  return std::stod(text.substr(at + series.size() + 2));
}

json Device(const json& devices, const std::string& name) {
  for (const auto& d : devices["items"]) {
    if (d["name"] == name) return d;
  }
  return json();
}

// Waits until pred(devices) holds (or the timeout passes); returns the last answer.
template <class Pred>
json WaitDevices(Api& api, Pred pred, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  json d;
  while (std::chrono::steady_clock::now() < end) {
    d = api.Get("/api/v1/devices");
    if (pred(d)) break;
    std::this_thread::sleep_for(50ms);
  }
  return d;
}

TEST(Acquisition, ModbusDevicePolledIntoAStreamSurvivesAServerRestart) {
  const fs::path dir = fs::temp_directory_path() / ("kinemetric-acq-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  auto modbus = std::make_unique<km::test::TestServer>(KM_MODBUS_TEST_SERVER, 0);
  const int mport = modbus->port();
  // Registers 100..101: milliseconds since the Modbus server started (uint32, ABCD); 102..103:
  // requests served. One block of 4 registers, polled every 10 ms.
  const json config = {
      {"devices",
       {{{"machine_id", "vmc-7"},
         {"name", "cap-rig"},
         {"host", "127.0.0.1"},
         {"port", mport},
         {"unit_id", 1},
         {"poll_interval_ms", 10},
         {"response_timeout_ms", 200},
         {"reconnect", {{"initial_ms", 50}, {"max_ms", 400}}},
         {"channels",
          {{{"channel", 1},
            {"name", "uptime"},
            {"address", 100},
            {"type", "uint32"},
            {"scale", 1e-3}},
           {{"channel", 2}, {"name", "requests"}, {"address", 102}, {"type", "uint32"}}}}}}}};
  const fs::path cfg = dir / "modbus.json";
  std::ofstream(cfg) << config.dump(2);
  {
    km::test::ServerProcess server(KINEMETRICD_BIN, (dir / "data").string(), kToken,
                                   "--modbus-config '" + cfg.string() + "'");
    Api api(server.port());
    json d = WaitDevices(
        api, [](const json& j) { return Device(j, "cap-rig")["status"]["polls_ok"] >= 50; }, 10s);
    json dev = Device(d, "cap-rig");
    ASSERT_TRUE(dev.is_object()) << d.dump();
    EXPECT_EQ(dev["machine_id"], "vmc-7");
    EXPECT_TRUE(dev["status"]["connected"].get<bool>()) << dev.dump();
    EXPECT_EQ(dev["status"]["state"], "connected");
    EXPECT_GT(dev["status"]["last_sample_t_us"].get<std::int64_t>(), 0);
    const auto stream_id = dev["stream_id"].get<std::int64_t>();

    // Outage: the Modbus server dies; after ~0.6 s it comes back on the same port.
    modbus->Kill();
    modbus.reset();
    d = WaitDevices(
        api, [](const json& j) { return !Device(j, "cap-rig")["status"]["connected"].get<bool>(); },
        5s);
    EXPECT_FALSE(Device(d, "cap-rig")["status"]["connected"].get<bool>()) << d.dump();
    std::this_thread::sleep_for(600ms);
    modbus = std::make_unique<km::test::TestServer>(KM_MODBUS_TEST_SERVER, mport);
    const auto polls_before = Device(d, "cap-rig")["status"]["polls_ok"].get<std::int64_t>();
    d = WaitDevices(
        api,
        [&](const json& j) {
          const auto s = Device(j, "cap-rig")["status"];
          return s["reconnects"] >= 1 && s["polls_ok"].get<std::int64_t>() > polls_before + 50;
        },
        10s);
    dev = Device(d, "cap-rig");
    EXPECT_GE(dev["status"]["reconnects"].get<int>(), 1) << dev.dump();
    EXPECT_GE(dev["status"]["connection_errors"].get<int>(), 1) << dev.dump();
    EXPECT_TRUE(dev["status"]["connected"].get<bool>()) << dev.dump();

    // A second device that cannot connect (nothing listens there) is counted, not fatal, and
    // does not slow the first one down.
    const int dead_port = km::test::FreeLoopbackPort();
    json second = config["devices"][0];
    second["name"] = "dead-rig";
    second["port"] = dead_port;
    auto added = api.Post("/api/v1/devices", second);
    ASSERT_TRUE(added);
    ASSERT_EQ(added->status, 201) << added->body;
    auto again = api.Post("/api/v1/devices", second);
    EXPECT_EQ(again->status, 400) << again->body;  // the name is taken
    json bad = second;
    bad["name"] = "typo-rig";
    bad["channels"][0]["type"] = "float64";
    auto refused = api.Post("/api/v1/devices", bad);
    ASSERT_EQ(refused->status, 400) << refused->body;
    EXPECT_EQ(json::parse(refused->body)["field"], "channels[0].type");
    const auto t_add = std::chrono::steady_clock::now();
    const auto polls_at_add = dev["status"]["polls_ok"].get<std::int64_t>();
    std::this_thread::sleep_for(1500ms);
    d = api.Get("/api/v1/devices");
    ASSERT_EQ(d["items"].size(), 2u);
    EXPECT_GE(Device(d, "dead-rig")["status"]["connection_errors"].get<int>(), 2) << d.dump();
    EXPECT_FALSE(Device(d, "dead-rig")["status"]["connected"].get<bool>());
    // The same figures in /metrics, per device (read after the list: counters only grew).
    const std::string m = api.Text("/metrics");
    const std::string cap = "{device=\"cap-rig\",machine_id=\"vmc-7\"",
                      dead = "{device=\"dead-rig\",machine_id=\"vmc-7\"";
    EXPECT_EQ(MetricValue(m, "kinemetric_modbus_device_connected" + cap + "}"), 1.0) << m;
    EXPECT_EQ(MetricValue(m, "kinemetric_modbus_device_connected" + dead + "}"), 0.0) << m;
    EXPECT_GE(MetricValue(m, "kinemetric_modbus_polls_total" + cap + "}"),
              Device(d, "cap-rig")["status"]["polls_ok"].get<double>());
    EXPECT_GE(MetricValue(m, "kinemetric_modbus_samples_total" + cap + "}"),
              Device(d, "cap-rig")["status"]["samples_delivered"].get<double>());
    EXPECT_GE(MetricValue(m, "kinemetric_modbus_reconnects_total" + cap + "}"), 1.0);
    EXPECT_GE(MetricValue(m, "kinemetric_modbus_errors_total" + dead + ",kind=\"connection\"}"),
              2.0);
    EXPECT_EQ(MetricValue(m, "kinemetric_modbus_errors_total" + cap + ",kind=\"exception\"}"), 0.0);
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_add).count();
    const auto polls_now = Device(d, "cap-rig")["status"]["polls_ok"].get<std::int64_t>();
    // 100 ticks a second; allow for a loaded machine, never for a stall.
    EXPECT_GT(static_cast<double>(polls_now - polls_at_add), 0.5 * 100.0 * secs) << d.dump();
    auto del = api.Delete("/api/v1/devices/dead-rig");
    ASSERT_TRUE(del);
    EXPECT_EQ(del->status, 200) << del->body;
    EXPECT_EQ(api.Get("/api/v1/devices")["items"].size(), 1u);
    EXPECT_EQ(api.Delete("/api/v1/devices/dead-rig")->status, 404);

    // Stored: per channel, every tick is either a sample or inside a recorded gap, and the
    // outage is recorded as a gap on both channels. The device is removed first, so the stream
    // stops growing and its counts are read between flushes, not across one (a live stream's
    // sample count and next counter come from two writes of the flush).
    ASSERT_EQ(api.Delete("/api/v1/devices/cap-rig")->status, 200);
    std::this_thread::sleep_for(1200ms);  // the hub writes buffered samples every second
    const json s = api.Get("/api/v1/streams/" + std::to_string(stream_id));
    EXPECT_EQ(s["source"], "modbus:cap-rig");
    ASSERT_EQ(s["channels"].size(), 2u) << s.dump();
    for (const auto& c : s["channels"]) {
      const auto samples = c["samples"].get<std::int64_t>();
      const auto missing = c["missing"].get<std::int64_t>();
      // Counting starts at tick 0; the background flush writes chunks and gaps together.
      EXPECT_EQ(samples + missing, c["next_counter"].get<std::int64_t>()) << c.dump();
      EXPECT_GE(c["gaps"].get<int>(), 1) << c.dump();
      // The outage lasted ≥ 0.6 s = 60 ticks.
      EXPECT_GE(missing, 50) << c.dump();
    }
    // The values are the registers: uptime in seconds increases with the counter and restarts
    // after the Modbus server came back.
    const json u = api.Get("/api/v1/streams/" + std::to_string(stream_id) +
                           "/samples?channel=1&max_points=1000000");
    ASSERT_FALSE(u["downsampled"].get<bool>());
    int restarts = 0;
    for (std::size_t i = 1; i < u["value_um"].size(); ++i) {
      const double a = u["value_um"][i - 1].get<double>(), b = u["value_um"][i].get<double>();
      if (b < a) ++restarts;
      EXPECT_GE(u["t_us"][i].get<std::int64_t>(), u["t_us"][i - 1].get<std::int64_t>());
    }
    EXPECT_EQ(restarts, 1);
    const json gaps = api.Get("/api/v1/streams/" + std::to_string(stream_id) + "/gaps");
    EXPECT_GE(gaps["items"].size(), 2u);
  }
  fs::remove_all(dir);
}

}  // namespace
