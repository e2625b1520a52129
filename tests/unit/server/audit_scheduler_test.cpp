// Accuracy audits over a real service and SQLite file (server/audits/audit_scheduler.h): runs over
// uploaded DBB tests with the evidence of each finding, trend rules against the previous
// audit, scheduled runs with a set clock (a time missed while the server was down runs once,
// also after a restart on the same database), the scheduler thread with a 1 s schedule and a
// prompt stop, a due run made once by one of two instances, a run whose claiming instance died
// made when the claim lapses, and the webhook delivered to a local HTTP receiver after a first
// 500.
#include "server/audits/audit_scheduler.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "analysis/core/errors.h"
#include "server/audits/audit_schedule.h"
#include "server/audits/audit_service.h"
#include "server/base/config.h"
#include "server/base/sha256.h"
#include "server/demo/demo_data.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
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
    RegisterBuiltinKinds(svc->measurements());
    return svc;
  }
  // Uploads the first demo DBB test; its id and circularity.
  std::pair<MeasurementId, double> UploadDbb(Service& svc) {
    const auto f = DemoDbbFiles().at(0);
    const auto out = svc.measurements().Upload(f.bytes, f.name);
    return {out.id, svc.measurements().Results(out.id)["circularity_um"].get<double>()};
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
  EXPECT_EQ(warn["findings"][0]["measurement_id"], json(id));
  EXPECT_EQ(warn["findings"][0]["value"], circ);
  EXPECT_EQ(warn["findings"][0]["limit"], circ - 1.0);
  EXPECT_EQ(warn["checked"][1]["status"], "not evaluated");
  EXPECT_TRUE(warn["webhook"].is_null());

  audits.PutConfig("demo-vmc", Rules(circ / 4, circ / 2));
  const json stop = audits.Run("demo-vmc", "manual");
  EXPECT_EQ(stop["level"], 3);
  EXPECT_EQ(stop["findings"][0]["limit"], circ / 2);
  EXPECT_EQ(AccuracyAuditJson(*svc, stop["id"].get<AuditVerdictId>()), stop);
  AuditVerdictFilter f;
  f.machine_id = "demo-vmc";
  const json list = ListAccuracyAudits(*svc, f);
  ASSERT_EQ(list["audits"].size(), 2u);
  EXPECT_EQ(list["audits"][0]["id"], stop["id"]);
  EXPECT_EQ(AuditConfigJson(*svc, "demo-vmc")["last_run_at"], "2026-11-27T03:12:00Z");
  f.from = "2026-11-27T03:12:00Z";  // inclusive
  EXPECT_EQ(ListAccuracyAudits(*svc, f)["audits"].size(), 2u);
  f.from.reset();
  f.to = "2026-11-27T03:12:00Z";  // exclusive
  EXPECT_TRUE(ListAccuracyAudits(*svc, f)["audits"].empty());
  f.to.reset();
  f.limit = 1;
  EXPECT_EQ(ListAccuracyAudits(*svc, f)["audits"][0]["id"], stop["id"]);
  f.machine_id = "other";
  EXPECT_TRUE(ListAccuracyAudits(*svc, f)["audits"].empty());
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
  EXPECT_EQ(second["checked"][0]["reference_measurement_id"], nlohmann::json(id));
  // A newer test of another plane is a set-up of its own: not compared with the one the
  // previous audit saw, which is still compared with itself.
  const auto yz = DemoDbbFiles().back();
  const auto yz_id = svc->measurements().Upload(yz.bytes, yz.name).id;
  const json third = audits.Run("demo-vmc", "manual");
  ASSERT_EQ(third["checked"].size(), 2u);
  EXPECT_EQ(third["checked"][0]["status"], "not evaluated");
  EXPECT_EQ(third["checked"][0]["measurement_id"], nlohmann::json(yz_id));
  EXPECT_EQ(third["checked"][0]["set_up"], "yz-r150 CW");
  EXPECT_EQ(third["checked"][0]["reason"],
            "no previous audit with a value of this metric in this set-up");
  EXPECT_EQ(third["checked"][1]["status"], "ok");
  EXPECT_EQ(third["checked"][1]["measurement_id"], nlohmann::json(id));
  EXPECT_EQ(third["checked"][1]["reference_measurement_id"], nlohmann::json(id));
}

// The demo machine's XY tests of 2 September, 1 October and 2 November 2026 (CCW and CW each),
// whose squareness, servo mismatch and backlash grow.
TEST_F(AccuracyAudits, DaysTrendsPairHysteresisAndDiagnosedEffectsFromStoredTests) {
  auto svc = Open();
  const auto files = DemoDbbFiles();
  for (std::size_t i = 0; i < 6; ++i) svc->measurements().Upload(files[i].bytes, files[i].name);
  AuditScheduler audits(*svc, {}, clock_);
  const json rules = {{{"kind", "dbb"},
                       {"metric", "circularity_um"},
                       {"change", "days"},
                       {"days", 40},
                       {"warn", 0}},
                      {{"kind", "dbb"}, {"metric", "circular_hysteresis_um"}, {"warn", 0}},
                      {{"kind", "dbb"}, {"metric", "diagnosis.backlash_x"}, {"warn", 0}},
                      {{"kind", "dbb"},
                       {"metric", "circularity_um"},
                       {"change", "days"},
                       {"days", 3650},
                       {"warn", 0}}};
  audits.PutConfig("demo-vmc", {{"rules", rules}});
  const json v = audits.Run("demo-vmc", "manual");
  // Every set-up: the CW and CCW circles of xy-r150 for each rule, their pair once for H.
  ASSERT_EQ(v["findings"].size(), 5u) << v.dump(1);
  const auto measured = [&](const json& id) {
    return svc->storage().GetMeasurement(id.get<MeasurementId>())->measured_at.value_or("");
  };
  const auto result = [&](const json& id) {
    return svc->measurements().Results(id.get<MeasurementId>());
  };

  const json& trend = v["findings"][0];
  EXPECT_EQ(trend["set_up"], "xy-r150 CW");
  EXPECT_EQ(v["findings"][1]["set_up"], "xy-r150 CCW");
  EXPECT_EQ(measured(trend["measurement_id"]), "2026-11-02T07:58:00Z");
  EXPECT_EQ(measured(trend["reference_measurement_id"]), "2026-10-01T08:05:00Z");
  const double newest = result(trend["measurement_id"])["circularity_um"].get<double>();
  const double older = result(trend["reference_measurement_id"])["circularity_um"].get<double>();
  EXPECT_EQ(trend["value"], newest - older);
  EXPECT_GT(newest - older, 0.0);

  const json& h = v["findings"][2];
  EXPECT_EQ(h["set_up"], "xy-r150");
  EXPECT_EQ(h["metric"], "circular_hysteresis_um");
  EXPECT_EQ(measured(h["measurement_id"]), "2026-11-02T07:58:00Z");
  EXPECT_EQ(
      h["value"],
      svc->DbbPairJson(h["measurement_id"].get<MeasurementId>())["pair"]["circular_hysteresis_um"]);

  const json& backlash = v["findings"][3];
  double expected = -1;
  const json diagnosed = result(backlash["measurement_id"]);  // kept alive over the loop
  for (const auto& d : diagnosed["diagnosis"]) {
    if (d["effect"] == "backlash_x") expected = std::abs(d["value"].get<double>());
  }
  EXPECT_EQ(backlash["value"], expected);
  EXPECT_NEAR(expected, 3.0, 0.1);  // 3 µm of backlash simulated

  EXPECT_EQ(v["checked"][5]["rule"], 3);
  EXPECT_EQ(v["checked"][5]["status"], "not evaluated");
  EXPECT_EQ(v["checked"][5]["reason"], "no result of xy-r150 CW at or before 2016-11-29T03:12:00Z");
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

// Two instances on one database, both finding the same run due at once (from threads): the run
// is claimed by one of them and made once.
TEST_F(AccuracyAudits, ADueRunIsMadeOnceByOneOfTwoInstances) {
  auto svc_a = Open();
  auto svc_b = Open();
  UploadDbb(*svc_a);
  AuditScheduler a(*svc_a, {}, clock_), b(*svc_b, {}, clock_);
  a.PutConfig("demo-vmc", Rules(1000, 2000, "every 1h"));
  for (int round = 1; round <= 5; ++round) {
    now_ += 3600;
    std::atomic<int> ran{0};
    std::thread ta([&] { ran += a.RunDue(); });
    std::thread tb([&] { ran += b.RunDue(); });
    ta.join();
    tb.join();
    EXPECT_EQ(ran.load(), 1) << "round " << round;
  }
  AuditVerdictFilter f;
  EXPECT_EQ(ListAccuracyAudits(*svc_b, f)["audits"].size(), 5u);
}

// Runs SQL on the database file through a connection of its own (as another process would).
void ExecSql(const std::string& path, const char* sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &err);
  EXPECT_EQ(rc, SQLITE_OK) << (err ? err : "");
  sqlite3_free(err);
  sqlite3_close(db);
}

// An instance that dies after claiming a due run, before its verdict is stored, leaves only its
// claim behind (simulated by a database that refuses everything the instance writes after the
// claim): the run is due again for any instance when the claim's lease ends, and made once.
TEST_F(AccuracyAudits, ARunClaimedByAnInstanceThatDiedIsMadeWhenItsLeaseEnds) {
  auto svc = Open();
  UploadDbb(*svc);
  AuditScheduler audits(*svc, {}, clock_);
  audits.PutConfig("demo-vmc", Rules(1000, 2000, "every 1h"));
  now_ += 3600;
  const std::int64_t claimed = now_;
  ExecSql(
      Path("k.db"),
      "CREATE TRIGGER died_verdict BEFORE INSERT ON audit_verdicts "
      "BEGIN SELECT RAISE(ABORT, 'instance died'); END;"
      "CREATE TRIGGER died_release BEFORE UPDATE ON audit_configs "
      "WHEN OLD.next_run_at > NEW.last_run_at BEGIN SELECT RAISE(ABORT, 'instance died'); END;");
  EXPECT_EQ(audits.RunDue(), 0);
  ExecSql(Path("k.db"), "DROP TRIGGER died_verdict; DROP TRIGGER died_release;");
  EXPECT_EQ(AuditConfigJson(*svc, "demo-vmc")["next_run_at"],
            IsoFromUnixSeconds(claimed + kAuditLeaseSeconds));
  EXPECT_EQ(audits.RunDue(), 0);
  now_ = claimed + kAuditLeaseSeconds - 1;
  EXPECT_EQ(audits.RunDue(), 0);
  now_ = claimed + kAuditLeaseSeconds;
  EXPECT_EQ(audits.RunDue(), 1);
  EXPECT_EQ(audits.RunDue(), 0);
  AuditVerdictFilter f;
  const json list = ListAccuracyAudits(*svc, f);
  ASSERT_EQ(list["audits"].size(), 1u);
  EXPECT_EQ(list["audits"][0]["trigger"], "schedule");
  EXPECT_EQ(list["audits"][0]["created_at"], IsoFromUnixSeconds(claimed + kAuditLeaseSeconds));
  // Back on the schedule: an hour after the late run.
  EXPECT_EQ(AuditConfigJson(*svc, "demo-vmc")["next_run_at"],
            IsoFromUnixSeconds(claimed + kAuditLeaseSeconds + 3600));
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

// A local receiver answering 500 to the first POST and 200 afterwards; it keeps each POST's
// body and its X-Kinemetric-* headers.
class Receiver {
 public:
  using Headers = std::map<std::string, std::string>;
  Receiver() {
    server_.Post("/hook", [this](const httplib::Request& req, httplib::Response& res) {
      std::lock_guard lock(mu_);
      bodies_.push_back(req.body);
      Headers h;
      for (const auto& [k, v] : req.headers)
        if (k.rfind("X-Kinemetric-", 0) == 0) h[k] = v;
      headers_.push_back(std::move(h));
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
  std::vector<Headers> headers() {
    std::lock_guard lock(mu_);
    return headers_;
  }

 private:
  httplib::Server server_;
  int port_ = 0;
  std::thread thread_;
  std::mutex mu_;
  std::vector<std::string> bodies_;
  std::vector<Headers> headers_;
};

TEST_F(AccuracyAudits, TheWebhookIsRetriedAfterA500AndTheDeliveryRecorded) {
  Receiver receiver;
  auto svc = Open();
  const auto [id, circ] = UploadDbb(*svc);
  AuditOptions o;
  o.webhook_url = "http://127.0.0.1:" + std::to_string(receiver.port()) + "/hook";
  o.webhook_allow_private = true;  // the receiver is on this host
  o.webhook_first_delay_ms = 100;
  AuditScheduler audits(*svc, o, clock_);
  audits.Start();
  audits.PutConfig("demo-vmc", Rules(circ - 1.0, circ + 1.0));
  const json v = audits.Run("demo-vmc", "manual");
  EXPECT_EQ(v["webhook"]["status"], "pending");
  const auto t0 = std::chrono::steady_clock::now();
  json stored;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10)) {
    stored = AccuracyAuditJson(*svc, v["id"].get<AuditVerdictId>());
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
  EXPECT_EQ(sent["findings"][0]["measurement_id"], nlohmann::json(id));
  // Level 1 sends nothing.
  audits.PutConfig("demo-vmc", Rules(1000, 2000));
  EXPECT_TRUE(audits.Run("demo-vmc", "manual")["webhook"].is_null());
  audits.Stop();
  EXPECT_EQ(receiver.bodies().size(), 2u);
}

// Each attempt names the verdict (the same delivery id, for the receiver to drop repeats), its
// attempt number and time, and is signed over "timestamp.body" with the configured secret.
TEST_F(AccuracyAudits, WebhookDeliveriesAreSignedAndNamedForTheReceiverToDropRepeats) {
  Receiver receiver;
  auto svc = Open();
  const auto circ = UploadDbb(*svc).second;
  AuditOptions o;
  o.webhook_url = "http://127.0.0.1:" + std::to_string(receiver.port()) + "/hook";
  o.webhook_allow_private = true;  // the receiver is on this host
  o.webhook_first_delay_ms = 50;
  o.webhook_secret = "correct horse battery staple";
  AuditScheduler audits(*svc, o, clock_);
  audits.Start();
  audits.PutConfig("demo-vmc", Rules(circ - 1.0, circ + 1.0));
  const json v = audits.Run("demo-vmc", "manual");
  const auto t0 = std::chrono::steady_clock::now();
  while (receiver.bodies().size() < 2 &&
         std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  audits.Stop();
  const auto bodies = receiver.bodies();
  const auto heads = receiver.headers();
  ASSERT_EQ(heads.size(), 2u);
  const auto now = std::chrono::duration_cast<std::chrono::seconds>(
                       std::chrono::system_clock::now().time_since_epoch())
                       .count();
  for (std::size_t k = 0; k < 2; ++k) {
    auto h = heads[k];
    EXPECT_EQ(h["X-Kinemetric-Delivery"], "audit-" + to_string(v["id"].get<AuditVerdictId>()));
    EXPECT_EQ(h["X-Kinemetric-Attempt"], std::to_string(k + 1));
    const std::int64_t ts = std::stoll(h["X-Kinemetric-Timestamp"]);
    EXPECT_LE(std::abs(now - ts), 30);
    EXPECT_EQ(
        h["X-Kinemetric-Signature"],
        "sha256=" + HmacSha256Hex(o.webhook_secret, h["X-Kinemetric-Timestamp"] + "." + bodies[k]));
    // A body changed on the way no longer matches the signature.
    EXPECT_NE(h["X-Kinemetric-Signature"],
              "sha256=" + HmacSha256Hex(o.webhook_secret,
                                        h["X-Kinemetric-Timestamp"] + "." + bodies[k] + " "));
  }
}

// Without a secret the deliveries carry no signature (and still their delivery id).
TEST(WebhookHeaders, UnsignedWithoutASecret) {
  WebhookOptions o;
  const auto h = WebhookHeaders(o, AuditVerdictId(7), 3, 1795749120, "{}");
  EXPECT_EQ(h, (std::vector<std::pair<std::string, std::string>>{
                   {"X-Kinemetric-Delivery", "audit-7"},
                   {"X-Kinemetric-Attempt", "3"},
                   {"X-Kinemetric-Timestamp", "1795749120"}}));
}

// RFC 4231 test cases 1, 2 and 6 (a key longer than the hash's block).
TEST(HmacSha256, MatchesTheRfc4231TestVectors) {
  EXPECT_EQ(HmacSha256Hex(std::string(20, '\x0b'), "Hi There"),
            "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7");
  EXPECT_EQ(HmacSha256Hex("Jefe", "what do ya want for nothing?"),
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
  EXPECT_EQ(HmacSha256Hex(std::string(131, '\xaa'),
                          "Test Using Larger Than Block-Size Key - Hash Key First"),
            "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54");
}

TEST_F(AccuracyAudits, AWebhookLeftPendingByAStopIsSentAtTheNextStart) {
  Receiver receiver;
  auto svc = Open();
  const auto [id, circ] = UploadDbb(*svc);
  AuditOptions o;
  o.webhook_url = "http://127.0.0.1:" + std::to_string(receiver.port()) + "/hook";
  o.webhook_allow_private = true;  // the receiver is on this host
  o.webhook_first_delay_ms = 50;
  json v;
  {
    AuditScheduler stopped(*svc, o, clock_);  // never started: the queue does not run
    stopped.PutConfig("demo-vmc", Rules(circ / 2, circ * 2));
    v = stopped.Run("demo-vmc", "manual");
  }
  EXPECT_EQ(AccuracyAuditJson(*svc, v["id"].get<AuditVerdictId>())["webhook"]["status"], "pending");
  EXPECT_TRUE(receiver.bodies().empty());
  AuditScheduler audits(*svc, o, clock_);
  audits.Start();
  const auto t0 = std::chrono::steady_clock::now();
  json stored;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10)) {
    stored = AccuracyAuditJson(*svc, v["id"].get<AuditVerdictId>());
    if (stored["webhook"]["status"] != "pending") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  audits.Stop();
  EXPECT_EQ(stored["webhook"], (json{{"status", "delivered"}, {"attempts", 2}}));
  ASSERT_EQ(receiver.bodies().size(), 2u);
  EXPECT_EQ(json::parse(receiver.bodies()[1])["id"], v["id"]);
}

TEST(AuditWebhookOptions, AreReadFromTheCommandLineAndChecked) {
  const auto cfg = ParseServerArgs(
      {"--audit-webhook-url", "http://hooks.example:9000/hook", "--audit-webhook-attempts", "3",
       "--audit-webhook-first-delay-ms", "250", "--audit-webhook-timeout-s", "2"});
  EXPECT_EQ(cfg.audit_webhook_url, "http://hooks.example:9000/hook");
  EXPECT_EQ(cfg.audit_webhook_attempts, 3);
  EXPECT_EQ(cfg.audit_webhook_first_delay_ms, 250);
  EXPECT_EQ(cfg.audit_webhook_timeout_s, 2);
  EXPECT_FALSE(cfg.audit_webhook_allow_private);
  const auto field = [](const std::vector<std::string>& args) {
    try {
      ParseServerArgs(args);
    } catch (const InvalidInput& e) {
      return e.field();
    }
    return std::string("accepted");
  };
  EXPECT_EQ(field({"--audit-webhook-url", "https://hooks.example/x"}), "--audit-webhook-url");
  EXPECT_EQ(field({"--audit-webhook-url", "http://:80/x"}), "--audit-webhook-url");
  EXPECT_EQ(field({"--audit-webhook-url", "http://h:99999/x"}), "--audit-webhook-url");
  EXPECT_EQ(field({"--audit-webhook-attempts", "0"}), "--audit-webhook-attempts");
  EXPECT_EQ(field({"--audit-webhook-attempts", "21"}), "--audit-webhook-attempts");
  EXPECT_EQ(field({"--audit-webhook-first-delay-ms", "5"}), "--audit-webhook-first-delay-ms");
  EXPECT_EQ(field({"--audit-webhook-timeout-s", "0"}), "--audit-webhook-timeout-s");
  EXPECT_EQ(field({"--audit-webhook-timeout-s", "301"}), "--audit-webhook-timeout-s");
  EXPECT_EQ(field({"--audit-webhook-url", "http://h/a b"}), "--audit-webhook-url");
}

// The signing secret comes from the config file (never the command line) or the environment;
// one too short is refused naming the file and the key, without echoing the secret.
TEST_F(AccuracyAudits, TheWebhookSecretIsReadFromTheConfigFileOrTheEnvironment) {
  const auto write = [&](const std::string& secret) {
    std::ofstream(Path("k.json")) << json{{"audit_webhook_secret", secret}}.dump();
    return Path("k.json");
  };
  EXPECT_EQ(ParseServerArgs({"--config", write("0123456789abcdef")}).audit_webhook_secret,
            "0123456789abcdef");
  try {
    ParseServerArgs({"--config", write("short-secret")});
    ADD_FAILURE() << "a 12-byte secret was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), Path("k.json"));
    EXPECT_EQ(e.field(), "audit_webhook_secret");
    EXPECT_EQ(std::string(e.what()).find("short-secret"), std::string::npos);
  }
  ::setenv("KINEMETRIC_AUDIT_WEBHOOK_SECRET", "from-the-environment", 1);
  EXPECT_EQ(ParseServerArgs({}).audit_webhook_secret, "from-the-environment");
  EXPECT_EQ(ParseServerArgs({"--config", write("0123456789abcdef")}).audit_webhook_secret,
            "0123456789abcdef");
  ::setenv("KINEMETRIC_AUDIT_WEBHOOK_SECRET", "tiny", 1);
  EXPECT_THROW(ParseServerArgs({}), InvalidInput);
  ::unsetenv("KINEMETRIC_AUDIT_WEBHOOK_SECRET");
  EXPECT_EQ(ParseServerArgs({}).audit_webhook_secret, "");
}

}  // namespace
}  // namespace km::server::test
