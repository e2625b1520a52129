// Limits of access beyond roles: CORS only for the configured origins (a real HTTP server), and
// Modbus devices added through the API only up to max_devices and only on allowed networks
// (the real router, service and SQLite storage), and the server options that set both.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "analysis/core/errors.h"
#include "api/http_server.h"
#include "api/routes.h"
#include "server/base/config.h"
#include "server/base/net_ranges.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/api/raw_client.h"

namespace km::api {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::RawConnection;
using test::StatusOf;

bool HasHeader(const std::string& response, const std::string& line) {
  const auto end = response.find("\r\n\r\n");
  return response.substr(0, end).find("\r\n" + line + "\r\n") != std::string::npos;
}

class Cors : public testing::Test {
 protected:
  void SetUp() override {
    router_.Add(Route{"GET", "/api/v1/thing", "", false, [](const Request&) {
                        return Response::Json({{"ok", true}});
                      }});
    HttpOptions o;
    o.port = 0;
    o.threads = 2;
    o.cors_origins = {"https://dash.example:8443"};
    server_ = std::make_unique<HttpServer>(router_, o);
    port_ = server_->Bind();
    thread_ = std::thread([this] { server_->Serve(); });
  }
  void TearDown() override {
    server_->Stop();
    thread_.join();
  }
  std::string Ask(const std::string& method, const std::string& extra_headers) {
    RawConnection c(port_);
    EXPECT_TRUE(c.Send(method + " /api/v1/thing HTTP/1.1\r\nHost: x\r\nConnection: close\r\n" +
                       extra_headers + "\r\n"));
    return c.ReadResponse(std::chrono::seconds(5)).value_or("");
  }

  Router router_;
  std::unique_ptr<HttpServer> server_;
  std::thread thread_;
  int port_ = 0;
};

TEST_F(Cors, OnlyTheConfiguredOriginGetsCorsHeaders) {
  const auto allowed = Ask("GET", "Origin: https://dash.example:8443\r\n");
  EXPECT_EQ(StatusOf(allowed), 200) << allowed;
  EXPECT_TRUE(HasHeader(allowed, "Access-Control-Allow-Origin: https://dash.example:8443"))
      << allowed;
  EXPECT_TRUE(HasHeader(allowed, "Vary: Origin")) << allowed;

  const auto other = Ask("GET", "Origin: https://evil.example\r\n");
  EXPECT_EQ(StatusOf(other), 200);
  EXPECT_EQ(other.find("Access-Control-Allow-Origin"), std::string::npos) << other;
  const auto none = Ask("GET", "");
  EXPECT_EQ(none.find("Access-Control-Allow-Origin"), std::string::npos) << none;

  const auto preflight = Ask("OPTIONS",
                             "Origin: https://dash.example:8443\r\n"
                             "Access-Control-Request-Method: POST\r\n"
                             "Access-Control-Request-Headers: authorization\r\n");
  EXPECT_EQ(StatusOf(preflight), 204) << preflight;
  EXPECT_TRUE(HasHeader(preflight, "Access-Control-Allow-Origin: https://dash.example:8443"));
  EXPECT_NE(preflight.find("Access-Control-Allow-Headers: Authorization"), std::string::npos);

  const auto refused = Ask("OPTIONS",
                           "Origin: https://evil.example\r\n"
                           "Access-Control-Request-Method: POST\r\n");
  EXPECT_EQ(StatusOf(refused), 403) << refused;
  EXPECT_EQ(refused.find("Access-Control-Allow-Origin"), std::string::npos) << refused;
  EXPECT_NE(refused.find("cors_origins"), std::string::npos) << refused;
}

TEST(CorsDefault, NoOriginIsAllowedUnlessConfigured) {
  Router router;
  router.Add(Route{"GET", "/x", "", false, [](const Request&) { return Response::Json({}); }});
  HttpOptions o;
  o.port = 0;
  o.threads = 1;
  HttpServer server(router, o);
  const int port = server.Bind();
  std::thread t([&] { server.Serve(); });
  RawConnection c(port);
  c.Send(
      "GET /x HTTP/1.1\r\nHost: x\r\nOrigin: http://127.0.0.1:8080\r\nConnection: close\r\n\r\n");
  const auto r = c.ReadResponse(std::chrono::seconds(5)).value_or("");
  EXPECT_EQ(StatusOf(r), 200) << r;
  EXPECT_EQ(r.find("Access-Control-Allow-Origin"), std::string::npos) << r;
  server.Stop();
  t.join();
}

json DeviceRequest(const std::string& name, const std::string& host) {
  return {{"machine_id", "vmc-7"},
          {"name", name},
          {"host", host},
          {"port", 1},  // nothing listens: the poller counts connection errors
          {"unit_id", 1},
          {"poll_interval_ms", 100},
          {"channels", json::array({{{"channel", 1}, {"address", 0}, {"type", "int16"}}})}};
}

class Devices : public testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::temp_directory_path() / ("km-devices-" + std::to_string(::getpid()) + "-" +
                                     testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    svc_ = std::make_unique<server::Service>(
        std::make_unique<server::SqliteStorage>((dir_ / "km.db").string()),
        server::ServiceOptions{});
    server::RegisterBuiltinKinds(svc_->measurements());
    AddRoutes(router_, *svc_);
    router_.SetHook(TokenHook(*svc_));
    ASSERT_EQ(svc_->access().EnsureAdminToken("boot"), "");
  }
  void TearDown() override {
    svc_.reset();
    fs::remove_all(dir_);
  }
  Response Call(const std::string& method, const std::string& path, const std::string& body = "") {
    Request req;
    req.method = method;
    req.path = path;
    req.headers["authorization"] = "Bearer boot";
    req.body = body;
    return router_.Dispatch(req);
  }

  fs::path dir_;
  std::unique_ptr<server::Service> svc_;
  Router router_;
};

TEST_F(Devices, HostsOutsideTheAllowedNetworksAreRefusedNamingTheReason) {
  // Default: loopback only.
  auto r = Call("POST", "/api/v1/devices", DeviceRequest("far", "10.0.0.5").dump());
  EXPECT_EQ(r.status, 403) << r.body;
  EXPECT_NE(r.body.find("device_networks: 127.0.0.0/8, ::1/128"), std::string::npos) << r.body;
  r = Call("POST", "/api/v1/devices", DeviceRequest("named", "plc.example").dump());
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_EQ(json::parse(r.body)["field"], "host");
  EXPECT_EQ(json::parse(Call("GET", "/api/v1/devices").body)["items"].size(), 0u);
  r = Call("POST", "/api/v1/devices", DeviceRequest("near", "127.0.0.1").dump());
  EXPECT_EQ(r.status, 201) << r.body;

  svc_->streams().acquisition().SetLimits({16, {"10.0.0.0/24"}});
  EXPECT_EQ(Call("POST", "/api/v1/devices", DeviceRequest("far", "10.0.0.5").dump()).status, 201);
  EXPECT_EQ(Call("POST", "/api/v1/devices", DeviceRequest("farther", "10.0.1.5").dump()).status,
            403);
  EXPECT_EQ(Call("POST", "/api/v1/devices", DeviceRequest("loop", "127.0.0.1").dump()).status, 403);
  EXPECT_THROW(svc_->streams().acquisition().SetLimits({16, {"10.0.0.0/33"}}), InvalidInput);
}

TEST_F(Devices, AtMostMaxDevicesRunAndAStoppedOneFreesItsPlace) {
  svc_->streams().acquisition().SetLimits({2, {"127.0.0.0/8"}});
  EXPECT_EQ(Call("POST", "/api/v1/devices", DeviceRequest("a", "127.0.0.1").dump()).status, 201);
  EXPECT_EQ(Call("POST", "/api/v1/devices", DeviceRequest("b", "localhost").dump()).status, 201);
  auto r = Call("POST", "/api/v1/devices", DeviceRequest("c", "127.0.0.2").dump());
  EXPECT_EQ(r.status, 403) << r.body;
  EXPECT_NE(r.body.find("at most 2 devices"), std::string::npos) << r.body;
  EXPECT_NE(r.body.find("max_devices"), std::string::npos) << r.body;
  // Refused devices opened no stream.
  EXPECT_EQ(json::parse(Call("GET", "/api/v1/streams").body)["items"].size(), 2u);
  EXPECT_EQ(Call("DELETE", "/api/v1/devices/a").status, 200);
  EXPECT_EQ(Call("POST", "/api/v1/devices", DeviceRequest("c", "127.0.0.2").dump()).status, 201);
  EXPECT_EQ(json::parse(Call("GET", "/api/v1/devices").body)["items"].size(), 2u);
}

TEST(NetRanges, CidrRangesHoldExactlyTheirAddresses) {
  const auto net = server::ParseNetwork("192.168.10.0/23");
  ASSERT_TRUE(net);
  EXPECT_TRUE(server::NetworkContains(*net, *server::ParseIpAddress("192.168.11.254")));
  EXPECT_FALSE(server::NetworkContains(*net, *server::ParseIpAddress("192.168.12.1")));
  EXPECT_FALSE(server::NetworkContains(*net, *server::ParseIpAddress("::ffff:192.168.10.1")));
  const auto v6 = server::ParseNetwork("::1/128");
  ASSERT_TRUE(v6);
  EXPECT_TRUE(server::NetworkContains(*v6, *server::ParseIpAddress("::1")));
  EXPECT_FALSE(server::NetworkContains(*v6, *server::ParseIpAddress("::2")));
  EXPECT_TRUE(server::NetworkContains(*server::ParseNetwork("0.0.0.0/0"),
                                      *server::ParseIpAddress("8.8.8.8")));
  for (const char* bad : {"10.0.0.0/", "10.0.0.0/33", "10.0.0/8", "localhost/8", "x", "::1/129"}) {
    EXPECT_FALSE(server::ParseNetwork(bad)) << bad;
  }
  EXPECT_FALSE(server::ParseIpAddress("plc.example"));
}

TEST(AccessOptions, OriginsAndNetworksAreReadAndCheckedFromTheCommandLine) {
  auto cfg = server::ParseServerArgs({"--cors-origin", "https://dash.example", "--device-network",
                                      "10.1.0.0/16", "--max-devices", "3"});
  EXPECT_EQ(cfg.cors_origins, std::vector<std::string>{"https://dash.example"});
  EXPECT_EQ(cfg.device_networks,
            (std::vector<std::string>{"127.0.0.0/8", "::1/128", "10.1.0.0/16"}));
  EXPECT_EQ(cfg.max_devices, 3u);
  EXPECT_TRUE(server::ParseServerArgs({}).cors_origins.empty());
  const auto refused = [](const std::vector<std::string>& args, const std::string& field) {
    try {
      server::ParseServerArgs(args);
      ADD_FAILURE() << "accepted " << args[0] << " " << args[1];
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), field);
    }
  };
  refused({"--cors-origin", "https://dash.example/path"}, "--cors-origin");
  refused({"--cors-origin", "*"}, "--cors-origin");
  refused({"--device-network", "10.1.0.0/40"}, "--device-network");
  refused({"--max-devices", "-1"}, "--max-devices");
}

TEST(AccessOptions, TheConfigFileListsOriginsAndReplacesTheNetworks) {
  const fs::path file =
      fs::temp_directory_path() / ("km-access-config-" + std::to_string(::getpid()) + ".json");
  const auto write = [&](const std::string& text) {
    std::ofstream(file) << text;
    return file.string();
  };
  auto cfg = server::ParseServerArgs(
      {"--config", write(R"({"cors_origins": ["http://a.example:8080", "https://b.example"],
                             "device_networks": ["192.168.10.0/24"], "max_devices": 0})")});
  EXPECT_EQ(cfg.cors_origins,
            (std::vector<std::string>{"http://a.example:8080", "https://b.example"}));
  EXPECT_EQ(cfg.device_networks, std::vector<std::string>{"192.168.10.0/24"});
  EXPECT_EQ(cfg.max_devices, 0u);
  const auto refused = [&](const std::string& text, const std::string& field) {
    try {
      server::ParseServerArgs({"--config", write(text)});
      ADD_FAILURE() << "accepted " << text;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), field) << e.what();
      EXPECT_EQ(e.file(), file.string());
    }
  };
  refused(R"({"cors_origins": ["https://a.example", "ftp://b"]})", "cors_origins[1]");
  refused(R"({"cors_origins": "https://a.example"})", "cors_origins");
  refused(R"({"device_networks": ["10.0.0.0/8", 7]})", "device_networks[1]");
  refused(R"({"max_devices": 10001})", "max_devices");
  fs::remove(file);
}

}  // namespace
}  // namespace km::api
