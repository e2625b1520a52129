// Accuracy audits on a real kinemetricd: rules stored over HTTP (an engineer's; a viewer is
// refused, bad rules answered 400 naming the rule and field), runs whose findings carry the
// uploaded DBB test's id and circularity (level 2 under warn, 3 under stop, a kind without
// results "not evaluated"), the verdict list in pages of at most 4 MiB (also of 200-rule
// verdicts) and the audit log, schedules that never fire refused, a 1 s schedule run by the
// server's thread, a schedule missed while the server was down run exactly once at the
// restart, and the webhook delivered to a local receiver after a first 500.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>

#include "server/demo/demo_data.h"
#include "tests/integration/server/server_process.h"

namespace km::audit::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const char* kAuditAdmin = "audit-integration-admin";

class AuditIntegration : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("kinemetric-audit-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    server_.reset();
    fs::remove_all(dir_);
  }
  void Start(const std::string& extra = "") {
    server_.reset();
    server_ = std::make_unique<km::test::ServerProcess>(KINEMETRICD_BIN, dir_.string(), kAuditAdmin,
                                                        extra);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    client_->set_read_timeout(20, 0);
  }
  static httplib::Headers Bearer(const std::string& token) {
    return {{"Authorization", "Bearer " + token}};
  }
  httplib::Result Put(const std::string& path, const json& body,
                      const std::string& token = kAuditAdmin) {
    return client_->Put(path, Bearer(token), body.dump(), "application/json");
  }
  json Get(const std::string& path) {
    auto r = client_->Get(path, Bearer(kAuditAdmin));
    EXPECT_TRUE(r);
    EXPECT_EQ(r->status, 200) << path << ": " << r->body;
    return json::parse(r->body);
  }
  json Run(const std::string& machine) {
    auto r = client_->Post("/api/v1/machines/" + machine + "/audit/run", Bearer(kAuditAdmin), "",
                           "application/json");
    EXPECT_TRUE(r);
    EXPECT_EQ(r->status, 201) << r->body;
    return json::parse(r->body);
  }
  // Uploads the first demo DBB test; its id and circularity.
  std::pair<std::int64_t, double> UploadDbb() {
    auto up = client_->Post("/api/v1/measurements", Bearer(kAuditAdmin),
                            km::server::DemoDbbFiles().at(0).bytes, "text/plain");
    EXPECT_EQ(up->status, 201) << up->body;
    const auto id = json::parse(up->body)["id"].get<std::int64_t>();
    const json results = Get("/api/v1/measurements/" + std::to_string(id) + "/results");
    return {id, results["circularity_um"].get<double>()};
  }
  static json Rules(double warn, double stop, const json& schedule = nullptr) {
    return {{"schedule", schedule},
            {"rules",
             {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", warn}, {"stop", stop}},
              {{"kind", "flatness"}, {"metric", "flatness_lsq_um"}, {"warn", 5}}}}};
  }
  // Waits until `done` holds or `seconds` pass.
  static bool WaitFor(const std::function<bool()>& done, int seconds) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
    while (std::chrono::steady_clock::now() < until) {
      if (done()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return done();
  }
  fs::path dir_;
  std::unique_ptr<km::test::ServerProcess> server_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(AuditIntegration, RulesRunsFindingsAndVerdictsOverHttp) {
  Start();
  const auto [id, circ] = UploadDbb();
  ASSERT_GT(circ, 2.0);
  auto viewer = client_->Post("/api/v1/tokens", Bearer(kAuditAdmin),
                              json{{"name", "v"}, {"role", "viewer"}}.dump(), "application/json");
  const std::string vt = json::parse(viewer->body)["token"];
  EXPECT_EQ(Put("/api/v1/machines/demo-vmc/audit", Rules(1, 2), vt)->status, 403);
  EXPECT_EQ(client_->Get("/api/v1/machines/demo-vmc/audit", Bearer(vt))->status, 404);

  auto bad = Put("/api/v1/machines/demo-vmc/audit",
                 {{"rules", {{{"kind", "dbb"}, {"metric", "roundness"}, {"warn", 1}}}}});
  EXPECT_EQ(bad->status, 400);
  EXPECT_EQ(json::parse(bad->body)["field"], "rules[0].metric") << bad->body;
  bad = Put("/api/v1/machines/demo-vmc/audit", Rules(3, 2));
  EXPECT_EQ(json::parse(bad->body)["field"], "rules[0].warn") << bad->body;
  bad = Put("/api/v1/machines/demo-vmc/audit", Rules(1, 2, "0 25 * * *"));
  EXPECT_EQ(bad->status, 400);
  EXPECT_EQ(json::parse(bad->body)["field"], "schedule") << bad->body;
  for (const char* never : {"0 0 31 2 *", "0 0 30 2 *", "0 0 31 4 *"}) {
    bad = Put("/api/v1/machines/demo-vmc/audit", Rules(1, 2, never));
    EXPECT_EQ(bad->status, 400) << never;
    EXPECT_EQ(json::parse(bad->body)["field"], "schedule") << bad->body;
    EXPECT_NE(bad->body.find("never fires"), std::string::npos) << bad->body;
  }
  for (const char* fires : {"0 0 29 2 *", "0 0 31 * *"}) {
    auto ok = Put("/api/v1/machines/leap-day/audit", Rules(1, 2, fires));
    ASSERT_EQ(ok->status, 200) << ok->body;
    EXPECT_TRUE(json::parse(ok->body)["next_run_at"].is_string()) << ok->body;
  }

  auto put = Put("/api/v1/machines/demo-vmc/audit", Rules(circ - 1.0, circ + 10.0));
  ASSERT_EQ(put->status, 200) << put->body;
  EXPECT_TRUE(json::parse(put->body)["next_run_at"].is_null());
  const json warn = Run("demo-vmc");
  EXPECT_EQ(warn["level"], 2);
  EXPECT_EQ(warn["trigger"], "manual");
  ASSERT_EQ(warn["findings"].size(), 1u);
  EXPECT_EQ(warn["findings"][0]["measurement_id"], id);
  EXPECT_EQ(warn["findings"][0]["value"], circ);
  EXPECT_EQ(warn["findings"][0]["limit"], circ - 1.0);
  EXPECT_EQ(warn["checked"][1]["status"], "not evaluated");

  ASSERT_EQ(Put("/api/v1/machines/demo-vmc/audit", Rules(circ / 4, circ / 2))->status, 200);
  const json stop = Run("demo-vmc");
  EXPECT_EQ(stop["level"], 3);
  EXPECT_EQ(stop["findings"][0]["limit"], circ / 2);
  EXPECT_EQ(Get("/api/v1/audits/" + stop["id"].dump()), stop);
  const json list = Get("/api/v1/audits?machine_id=demo-vmc");
  ASSERT_EQ(list["audits"].size(), 2u);
  EXPECT_EQ(list["audits"][0]["id"], stop["id"]);
  EXPECT_EQ(list["audits"][1]["id"], warn["id"]);
  EXPECT_TRUE(Get("/api/v1/audits?machine_id=other")["audits"].empty());
  EXPECT_EQ(list.at("limit"), 100);
  EXPECT_EQ(list.at("offset"), 0);
  EXPECT_EQ(list.at("truncated"), false);
  EXPECT_TRUE(list.at("next_offset").is_null());
  const json newest = Get("/api/v1/audits?machine_id=demo-vmc&limit=1");
  EXPECT_EQ(newest["audits"], json::array({stop}));
  EXPECT_EQ(newest.at("next_offset"), 1);
  const json older = Get("/api/v1/audits?machine_id=demo-vmc&limit=1&offset=1");
  EXPECT_EQ(older["audits"][0]["id"], warn["id"]);
  EXPECT_TRUE(older.at("next_offset").is_null());
  auto bad_offset = client_->Get("/api/v1/audits?offset=-1", Bearer(kAuditAdmin));
  EXPECT_EQ(bad_offset->status, 400);
  EXPECT_EQ(json::parse(bad_offset->body)["field"], "offset");
  EXPECT_EQ(Get("/api/v1/machines/demo-vmc/audit")["rules"][0]["warn"], circ / 4);
  EXPECT_GE(Get("/api/v1/audit-metrics")["metrics"].size(), 15u);
  EXPECT_EQ(client_->Get("/api/v1/audits/999", Bearer(kAuditAdmin))->status, 404);

  const json log = Get("/api/v1/audit-log")["items"];
  EXPECT_EQ(log[0]["method"], "POST");
  EXPECT_EQ(log[0]["subject"], "machine demo-vmc, audit " + stop["id"].dump());
  EXPECT_EQ(log[1]["method"], "PUT");
  EXPECT_EQ(log[1]["path"], "/api/v1/machines/demo-vmc/audit");
}

// The number of verdicts of a machine with trigger "schedule".
int Scheduled(const json& list) {
  int n = 0;
  for (const auto& a : list["audits"]) n += a["trigger"] == "schedule";
  return n;
}

TEST_F(AuditIntegration, ManyLargeVerdictsAreListedAPageOfAtMostFourMiBAtATime) {
  Start();
  UploadDbb();
  const char* metrics[] = {"circularity_um", "min_zone_circularity_um", "centre_offset_um",
                           "circular_deviation_um", "average_radial_error_um"};
  json rules = json::array();
  for (int i = 0; i < 200; ++i) {
    rules.push_back({{"kind", "dbb"}, {"metric", metrics[i % 5]}, {"warn", 0.0}});
  }
  ASSERT_EQ(Put("/api/v1/machines/demo-vmc/audit", {{"rules", rules}})->status, 200);
  constexpr int kRuns = 70;  // about 80 kB each: more than a page
  for (int i = 0; i < kRuns; ++i) ASSERT_EQ(Run("demo-vmc")["findings"].size(), 200u);

  std::set<std::int64_t> seen;
  std::string offset = "0";
  int pages = 0;
  while (++pages < 50) {
    auto r = client_->Get("/api/v1/audits?limit=1000&offset=" + offset, Bearer(kAuditAdmin));
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200);
    EXPECT_LE(r->body.size(), std::size_t{4} << 20);
    const json page = json::parse(r->body);
    for (const auto& v : page["audits"]) {
      EXPECT_TRUE(seen.insert(v["id"].get<std::int64_t>()).second) << v["id"];
    }
    if (page.at("next_offset").is_null()) break;
    EXPECT_EQ(page.at("truncated"), true);
    offset = page.at("next_offset").dump();
  }
  EXPECT_EQ(seen.size(), static_cast<std::size_t>(kRuns));
  EXPECT_GE(pages, 2);
}

TEST_F(AuditIntegration, TheServerRunsSchedulesAndOnceForATimeMissedWhileDown) {
  Start();
  ASSERT_EQ(Put("/api/v1/machines/m1/audit", Rules(1, 2, "every 1s"))->status, 200);
  EXPECT_TRUE(WaitFor([&] { return Scheduled(Get("/api/v1/audits?machine_id=m1")) >= 2; }, 8));
  ASSERT_EQ(Put("/api/v1/machines/m1/audit", Rules(1, 2, "every 24h"))->status, 200);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a run under way ends
  const int before = Scheduled(Get("/api/v1/audits?machine_id=m1"));
  server_->Stop();
  // Down past ten due times: the stored next run lies ten days back.
  const char* back =
      "UPDATE audit_configs SET next_run_at = '2020-01-01T00:00:00Z' WHERE machine_id = 'm1'";
  if (km::test::OnPostgresql()) {
    ASSERT_TRUE(km::test::RunPostgresql(dir_.string(), back));
  } else {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir_ / "kinemetric.db").c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, back, nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  Start();
  EXPECT_TRUE(
      WaitFor([&] { return Scheduled(Get("/api/v1/audits?machine_id=m1")) == before + 1; }, 5));
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  EXPECT_EQ(Scheduled(Get("/api/v1/audits?machine_id=m1")), before + 1);
  const json config = Get("/api/v1/machines/m1/audit");
  EXPECT_GT(config["next_run_at"].get<std::string>(), config["last_run_at"].get<std::string>());
  EXPECT_GT(config["next_run_at"].get<std::string>(), "2026-01-01");
}

TEST_F(AuditIntegration, TheWebhookIsDeliveredAfterAFirst500) {
  httplib::Server receiver;
  std::mutex mu;
  std::vector<std::string> bodies;
  receiver.Post("/hook", [&](const httplib::Request& req, httplib::Response& res) {
    std::lock_guard lock(mu);
    bodies.push_back(req.body);
    res.status = bodies.size() == 1 ? 500 : 204;
  });
  const int port = receiver.bind_to_any_port("127.0.0.1");
  std::thread serving([&] { receiver.listen_after_bind(); });
  Start("--audit-webhook-url http://127.0.0.1:" + std::to_string(port) +
        "/hook --audit-webhook-first-delay-ms 200 --audit-webhook-allow-private");
  const auto [id, circ] = UploadDbb();
  ASSERT_EQ(Put("/api/v1/machines/demo-vmc/audit", Rules(circ - 1.0, circ + 10.0))->status, 200);
  const json v = Run("demo-vmc");
  EXPECT_EQ(v["webhook"]["status"], "pending");
  json stored;
  EXPECT_TRUE(WaitFor(
      [&] {
        stored = Get("/api/v1/audits/" + v["id"].dump());
        return stored["webhook"]["status"] != "pending";
      },
      10));
  EXPECT_EQ(stored["webhook"], (json{{"status", "delivered"}, {"attempts", 2}}));
  receiver.stop();
  serving.join();
  ASSERT_EQ(bodies.size(), 2u);
  const json sent = json::parse(bodies[1]);
  EXPECT_EQ(sent["level"], 2);
  EXPECT_EQ(sent["machine_id"], "demo-vmc");
  EXPECT_EQ(sent["findings"][0]["measurement_id"], id);
  EXPECT_EQ(sent["findings"][0]["value"], circ);
}

}  // namespace
}  // namespace km::audit::test
