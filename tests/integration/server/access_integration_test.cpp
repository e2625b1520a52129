// Integration test of access control on a real kinemetricd: tokens made over HTTP, a viewer
// refused an upload (403) that an operator may do, revocation effective at the next request,
// the audit log of the upload and the revocation kept across a restart, CORS for the configured
// origin only, and Modbus devices limited in number and network.
#include <gtest/gtest.h>
#include <httplib.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "server/demo/demo_data.h"
#include "tests/integration/server/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char* kAccessAdmin = "access-integration-admin";

class AccessIntegration : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("kinemetric-access-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::unique_ptr<km::test::ServerProcess> Start(const std::string& extra = "") {
    return std::make_unique<km::test::ServerProcess>(KINEMETRICD_BIN, dir_.string(), kAccessAdmin,
                                                     extra);
  }
  static httplib::Headers Bearer(const std::string& token) {
    return {{"Authorization", "Bearer " + token}};
  }
  fs::path dir_;
};

TEST_F(AccessIntegration, RolesTokensRevocationAndTheAuditLogOverHttp) {
  auto server = Start();
  httplib::Client c("127.0.0.1", server->port());
  c.set_read_timeout(10, 0);
  const auto make = [&](const std::string& role) {
    auto r = c.Post("/api/v1/tokens", Bearer(kAccessAdmin),
                    json{{"name", role + " at line 1"}, {"role", role}}.dump(), "application/json");
    EXPECT_TRUE(r);
    EXPECT_EQ(r->status, 201) << r->body;
    return json::parse(r->body);
  };
  const json viewer = make("viewer");
  const json op = make("operator");
  const std::string file = km::server::DemoDbbFiles().at(0).bytes;

  auto refused = c.Post("/api/v1/measurements", Bearer(viewer["token"]), file, "text/plain");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 403);
  EXPECT_EQ(refused->get_header_value("Content-Type"), "application/problem+json");
  EXPECT_NE(refused->body.find("'operator'"), std::string::npos) << refused->body;
  EXPECT_EQ(c.Get("/api/v1/measurements", Bearer(viewer["token"]))->status, 200);
  EXPECT_EQ(c.Get("/api/v1/tokens", Bearer(op["token"]))->status, 403);
  EXPECT_EQ(c.Get("/api/v1/measurements", Bearer("guess"))->status, 401);

  auto up = c.Post("/api/v1/measurements", Bearer(op["token"]), file, "text/plain");
  ASSERT_TRUE(up);
  ASSERT_EQ(up->status, 201) << up->body;
  const auto mid = json::parse(up->body)["id"].get<std::int64_t>();

  auto del = c.Delete("/api/v1/tokens/" + op["id"].dump(), Bearer(kAccessAdmin));
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 200) << del->body;
  auto after = c.Get("/api/v1/measurements", Bearer(op["token"]));
  EXPECT_EQ(after->status, 401);
  EXPECT_EQ(after->get_header_value("WWW-Authenticate"), "Bearer");

  const auto tokens = c.Get("/api/v1/tokens", Bearer(kAccessAdmin));
  ASSERT_EQ(tokens->status, 200);
  EXPECT_EQ(tokens->body.find(op["token"].get<std::string>()), std::string::npos);
  EXPECT_EQ(tokens->body.find(kAccessAdmin), std::string::npos);

  // The audit log survives a restart.
  EXPECT_EQ(server->Stop(), 0);
  server = Start();
  httplib::Client c2("127.0.0.1", server->port());
  auto log = c2.Get("/api/v1/audit-log", Bearer(kAccessAdmin));
  ASSERT_TRUE(log);
  ASSERT_EQ(log->status, 200) << log->body;
  const json items = json::parse(log->body)["items"];
  bool upload_seen = false, revoke_seen = false;
  for (const auto& e : items) {
    if (e["method"] == "POST" && e["path"] == "/api/v1/measurements" && e["status"] == 201) {
      upload_seen = true;
      EXPECT_EQ(e["token_id"], op["id"]);
      EXPECT_EQ(e["role"], "operator");
      EXPECT_EQ(e["subject"], "measurement " + std::to_string(mid));
    }
    if (e["method"] == "DELETE") {
      revoke_seen = true;
      EXPECT_EQ(e["subject"], "token " + op["id"].dump());
      EXPECT_EQ(e["token_name"], "bootstrap");
    }
  }
  EXPECT_TRUE(upload_seen) << items.dump(1);
  EXPECT_TRUE(revoke_seen) << items.dump(1);
  // Revoked stays revoked after the restart.
  EXPECT_EQ(c2.Get("/api/v1/machines", Bearer(op["token"]))->status, 401);
  EXPECT_EQ(c2.Get("/api/v1/machines", Bearer(viewer["token"]))->status, 200);
}

TEST_F(AccessIntegration, CorsForTheConfiguredOriginAndDeviceLimits) {
  auto server = Start("--cors-origin https://dash.example --max-devices 1");
  httplib::Client c("127.0.0.1", server->port());
  c.set_read_timeout(10, 0);
  httplib::Headers h = Bearer(kAccessAdmin);
  h.emplace("Origin", "https://dash.example");
  auto ok = c.Get("/api/v1/machines", h);
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->get_header_value("Access-Control-Allow-Origin"), "https://dash.example");
  httplib::Headers other = Bearer(kAccessAdmin);
  other.emplace("Origin", "https://elsewhere.example");
  auto no = c.Get("/api/v1/machines", other);
  ASSERT_TRUE(no);
  EXPECT_EQ(no->status, 200);
  EXPECT_FALSE(no->has_header("Access-Control-Allow-Origin"));

  const auto device = [](const std::string& name, const std::string& host) {
    return json{{"machine_id", "vmc-7"},
                {"name", name},
                {"host", host},
                {"port", 1},
                {"poll_interval_ms", 100},
                {"channels", json::array({{{"channel", 1}, {"address", 0}, {"type", "int16"}}})}}
        .dump();
  };
  auto far = c.Post("/api/v1/devices", Bearer(kAccessAdmin), device("far", "192.0.2.7"),
                    "application/json");
  EXPECT_EQ(far->status, 403) << far->body;
  EXPECT_NE(far->body.find("device_networks"), std::string::npos) << far->body;
  EXPECT_EQ(
      c.Post("/api/v1/devices", Bearer(kAccessAdmin), device("a", "127.0.0.1"), "application/json")
          ->status,
      201);
  auto second =
      c.Post("/api/v1/devices", Bearer(kAccessAdmin), device("b", "127.0.0.1"), "application/json");
  EXPECT_EQ(second->status, 403) << second->body;
  EXPECT_NE(second->body.find("max_devices"), std::string::npos) << second->body;
}

}  // namespace
