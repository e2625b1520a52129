// Accuracy audits over a real service and SQLite file (server/audit_scheduler.h): runs over
// uploaded DBB tests with the evidence of each finding, trend rules against the previous
// audit, scheduled runs with a set clock (a time missed while the server was down runs once,
// also after a restart on the same database), the scheduler thread with a 1 s schedule and a
// prompt stop, and the webhook delivered to a local HTTP receiver after a first 500.
#include "server/audit_scheduler.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <thread>

#include "analysis/core/errors.h"
#include "server/audit_schedule.h"
#include "server/audit_service.h"
#include "server/demo_data.h"
#include "server/service.h"
#include "server/sqlite_storage.h"
#include "tests/unit/server/temp_dir.h"

// Eigen (through service.h) before httplib: <resolv.h> (pulled in by httplib) defines _res.
#include <httplib.h>

namespace km::server::test {
namespace {

using nlohmann::json;

class AccuracyAudits : public TempDirTest {
 protected:
  std::unique_ptr<Service> Open() {
    auto svc =
        std::make_unique<Service>(std::make_unique<SqliteStorage>(Path("k.db")), ServiceOptions{});
    RegisterBuiltinKinds(*svc);
    return svc;
  }
  // Uploads the first demo DBB test; its id and circularity.
  std::pair<std::int64_t, double> UploadDbb(Service& svc) {
    const auto f = DemoDbbFiles().at(0);
    const auto out = svc.Upload(f.bytes, f.name);
    return {out.id, svc.Results(out.id)["circularity_um"].get<double>()};
  }
  static json Rules(double warn, double stop, const std::string& schedule = "") {
    json body = {{"rules",
                  {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", warn}, {"stop", stop}},
                   {{"kind", "flatness"}, {"metric", "flatness_lsq_um"}, {"warn", 1}}}}};
    body["schedule"] = schedule.empty() ? json(nullptr) : json(schedule);
    return body;
  }
  std::atomic<std::int64_t> now_{1795749120};  // 2026-11-27T03:12:00Z
  AuditClock clock_ = [this] { return now_.load(); };
};

TEST_F(AccuracyAudits, ARunFindsTheNewestResultAboveTheLimitsWithItsEvidence) {
  auto svc = Open();
  const auto [id, circ] = UploadDbb(*svc);
  ASSERT_GT(circ, 1.0);
  AuditScheduler audits(*svc, {}, clock_);
  EXPECT_THROW(audits.Run("demo-vmc", "manual"), NotFound);
  audits.PutConfig("demo-vmc", Rules(circ - 1.0, circ + 1.0));
  const json warn = audits.Run("demo-vmc", "manual");
  EXPECT_EQ(warn["level"], 2);
  EXPECT_EQ(warn["trigger"], "manual");
  EXPECT_EQ(warn["created_at"], "2026-11-27T03:12:00Z");
  ASSERT_EQ(warn["findings"].size(), 1u);
  EXPECT_EQ(warn["findings"][0]["measurement_id"], id);
  EXPECT_EQ(warn["findings"][0]["value"], circ);
  EXPECT_EQ(warn["findings"][0]["limit"], circ - 1.0);
  EXPECT_EQ(warn["checked"][1]["status"], "not evaluated");
  EXPECT_TRUE(warn["webhook"].is_null());

  audits.PutConfig("demo-vmc", Rules(circ / 4, circ / 2));
  const json stop = audits.Run("demo-vmc", "manual");
  EXPECT_EQ(stop["level"], 3);
  EXPECT_EQ(stop["findings"][0]["limit"], circ / 2);
  EXPECT_EQ(AccuracyAuditJson(*svc, stop["id"].get<std::int64_t>()), stop);
  AuditVerdictFilter f;
  f.machine_id = "demo-vmc";
  const json list = ListAccuracyAudits(*svc, f);
  ASSERT_EQ(list["audits"].size(), 2u);
  EXPECT_EQ(list["audits"][0]["id"], stop["id"]);
  EXPECT_EQ(AuditConfigJson(*svc, "demo-vmc")["last_run_at"], "2026-11-27T03:12:00Z");
}

TEST_F(AccuracyAudits, PreviousAuditTrendComparesWithTheValueThatAuditSaw) {
  auto svc = Open();
  const auto [id, circ] = UploadDbb(*svc);
  AuditScheduler audits(*svc, {}, clock_);
  const json trend = {{"rules",
                       {{{"kind", "dbb"},
                         {"metric", "circularity_um"},
                         {"change", "previous_audit"},
                         {"warn", 0.5}}}}};
  audits.PutConfig("demo-vmc", trend);
  const json first = audits.Run("demo-vmc", "manual");
  EXPECT_EQ(first["checked"][0]["status"], "not evaluated");
  EXPECT_EQ(first["checked"][0]["value"], circ);
  const json second = audits.Run("demo-vmc", "manual");
  EXPECT_EQ(second["level"], 1);
  EXPECT_EQ(second["checked"][0]["status"], "ok");
  EXPECT_EQ(second["checked"][0]["value"], 0.0);
  EXPECT_EQ(second["checked"][0]["reference_measurement_id"], id);
}

TEST_F(AccuracyAudits, AMissedScheduleRunsOnceAlsoAfterARestart) {
  {
    auto svc = Open();
    UploadDbb(*svc);
    AuditScheduler audits(*svc, {}, clock_);
    const json c = audits.PutConfig("demo-vmc", Rules(1000, 2000, "every 1h"));
    EXPECT_EQ(c["next_run_at"], "2026-11-27T04:12:00Z");
    EXPECT_EQ(audits.RunDue(), 0);
    now_ += 3600;
    EXPECT_EQ(audits.RunDue(), 1);
    EXPECT_EQ(audits.RunDue(), 0);
    EXPECT_EQ(AuditConfigJson(*svc, "demo-vmc")["next_run_at"], "2026-11-27T05:12:00Z");
  }
  now_ += 10 * 3600;  // down for ten hours: ten runs missed
  auto svc = Open();
  AuditScheduler audits(*svc, {}, clock_);
  EXPECT_EQ(audits.RunDue(), 1);
  EXPECT_EQ(audits.RunDue(), 0);
  AuditVerdictFilter f;
  const json list = ListAccuracyAudits(*svc, f);
  ASSERT_EQ(list["audits"].size(), 2u);
  EXPECT_EQ(list["audits"][0]["trigger"], "schedule");
  EXPECT_EQ(list["audits"][0]["created_at"], "2026-11-27T14:12:00Z");
  EXPECT_EQ(list["audits"][0]["level"], 1);
  EXPECT_EQ(AuditConfigJson(*svc, "demo-vmc")["next_run_at"], "2026-11-27T15:12:00Z");
}

TEST_F(AccuracyAudits, TheThreadRunsAOneSecondScheduleAndStopsPromptly) {
  auto svc = Open();
  AuditScheduler audits(*svc, {});
  audits.Start();
  audits.PutConfig("m1", Rules(1, 2, "every 1s"));
  const auto start = std::chrono::steady_clock::now();
  std::size_t runs = 0;
  while (runs < 2 && std::chrono::steady_clock::now() - start < std::chrono::seconds(6)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    runs = ListAccuracyAudits(*svc, {})["audits"].size();
  }
  EXPECT_GE(runs, 2u);
  const auto stop_at = std::chrono::steady_clock::now();
  audits.Stop();
  EXPECT_LT(std::chrono::steady_clock::now() - stop_at, std::chrono::milliseconds(500));
  const json v = ListAccuracyAudits(*svc, {})["audits"][0];
  EXPECT_EQ(v["trigger"], "schedule");
  EXPECT_EQ(v["checked"][0]["status"], "not evaluated");
}

// A local receiver answering 500 to the first POST and 200 afterwards.
class Receiver {
 public:
  Receiver() {
    server_.Post("/hook", [this](const httplib::Request& req, httplib::Response& res) {
      std::lock_guard lock(mu_);
      bodies_.push_back(req.body);
      res.status = bodies_.size() == 1 ? 500 : 200;
    });
    port_ = server_.bind_to_any_port("127.0.0.1");
    thread_ = std::thread([this] { server_.listen_after_bind(); });
  }
  ~Receiver() {
    server_.stop();
    thread_.join();
  }
  int port() const { return port_; }
  std::vector<std::string> bodies() {
    std::lock_guard lock(mu_);
    return bodies_;
  }

 private:
  httplib::Server server_;
  int port_ = 0;
  std::thread thread_;
  std::mutex mu_;
  std::vector<std::string> bodies_;
};

TEST_F(AccuracyAudits, TheWebhookIsRetriedAfterA500AndTheDeliveryRecorded) {
  Receiver receiver;
  auto svc = Open();
  const auto [id, circ] = UploadDbb(*svc);
  AuditOptions o;
  o.webhook_url = "http://127.0.0.1:" + std::to_string(receiver.port()) + "/hook";
  o.webhook_first_delay_ms = 100;
  AuditScheduler audits(*svc, o, clock_);
  audits.Start();
  audits.PutConfig("demo-vmc", Rules(circ - 1.0, circ + 1.0));
  const json v = audits.Run("demo-vmc", "manual");
  EXPECT_EQ(v["webhook"]["status"], "pending");
  const auto t0 = std::chrono::steady_clock::now();
  json stored;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10)) {
    stored = AccuracyAuditJson(*svc, v["id"].get<std::int64_t>());
    if (stored["webhook"]["status"] != "pending") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(stored["webhook"], (json{{"status", "delivered"}, {"attempts", 2}}));
  const auto bodies = receiver.bodies();
  ASSERT_EQ(bodies.size(), 2u);
  EXPECT_EQ(bodies[0], bodies[1]);
  const json sent = json::parse(bodies[1]);
  EXPECT_EQ(sent["id"], v["id"]);
  EXPECT_EQ(sent["level"], 2);
  EXPECT_EQ(sent["findings"][0]["measurement_id"], id);
  // Level 1 sends nothing.
  audits.PutConfig("demo-vmc", Rules(1000, 2000));
  EXPECT_TRUE(audits.Run("demo-vmc", "manual")["webhook"].is_null());
  audits.Stop();
  EXPECT_EQ(receiver.bodies().size(), 2u);
}

}  // namespace
}  // namespace km::server::test
