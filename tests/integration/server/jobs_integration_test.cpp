// Integration test of cancelling a background job on a real kinemetricd (one job worker): a long
// calibration with a reduction study is cancelled by its owner and stops promptly, the worker
// runs the next job at once, and the cancelled job stays cancelled; a viewer and another
// engineer are refused (403), an unknown job is 404, a finished one 409; an admin cancels any
// job, also a queued one, which never runs. A request the job would refuse is refused at once.
// Eigen before httplib: <resolv.h> (pulled in by httplib) defines the macro _res.
#include "analysis/sim/hexapod_dbb_sim.h"
#include "ingest/dbb_writer.h"
#include "ingest/machine_json.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "tests/integration/server/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

const char* kJobsAdmin = "jobs-integration-admin";

class JobsIntegration : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("kinemetric-jobs-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    server_ = std::make_unique<km::test::ServerProcess>(KINEMETRICD_BIN, dir_.string(), kJobsAdmin,
                                                        "--job-workers 1");
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    client_->set_read_timeout(30, 0);
  }
  void TearDown() override {
    client_.reset();
    server_.reset();
    fs::remove_all(dir_);
  }
  static httplib::Headers Bearer(const std::string& token) {
    return {{"Authorization", "Bearer " + token}};
  }
  // A new token of the role: its secret.
  std::string Token(const std::string& role, const std::string& name) {
    auto r = client_->Post("/api/v1/tokens", Bearer(kJobsAdmin),
                           json{{"name", name}, {"role", role}}.dump(), "application/json");
    EXPECT_TRUE(r && r->status == 201) << (r ? r->body : "no answer");
    return json::parse(r->body)["token"];
  }
  // The simulated DBB tests of a hexapod (the calibration plan of [PM-600 report] table 2.1),
  // uploaded; the request of a calibration of them.
  json CalibrationRequest() {
    const std::string machine_text =
        km::test::ReadFileText(KINEMETRIC_SOURCE_DIR "/tests/fixtures/pm600-like.json");
    const auto machine = km::ingest::ParseHexapodMachineJson(machine_text, "pm600-like.json");
    const auto truth = km::sim::PerturbGeometry(machine.geometry, 0.3, 0.1, 11);
    km::sim::HexapodDbbSimOptions so;
    so.noise_um = 0.3;
    json ids = json::array();
    for (const auto& t : km::sim::SimulateHexapodDbbPlan(machine.geometry, truth,
                                                         km::sim::Table21Plan(180, false), so)) {
      auto r = client_->Post("/api/v1/measurements", Bearer(kJobsAdmin), km::ingest::WriteDbb(t),
                             "text/plain");
      EXPECT_TRUE(r && r->status == 201) << (r ? r->body : "no answer");
      ids.push_back(json::parse(r->body)["id"]);
    }
    return {{"machine", json::parse(machine_text)}, {"measurement_ids", ids}};
  }
  httplib::Result Submit(const std::string& token, const json& request) {
    return client_->Post("/api/v1/calibrations", Bearer(token), request.dump(), "application/json");
  }
  std::int64_t SubmitJob(const std::string& token, const json& request) {
    auto r = Submit(token, request);
    EXPECT_TRUE(r && r->status == 202) << (r ? r->body : "no answer");
    return json::parse(r->body)["job_id"];
  }
  json Job(std::int64_t id) {
    auto r = client_->Get("/api/v1/jobs/" + std::to_string(id), Bearer(kJobsAdmin));
    EXPECT_TRUE(r && r->status == 200);
    return json::parse(r->body);
  }
  // Waits (up to `seconds`) until the job is in a state `pred` accepts; the job as last seen.
  template <class Pred>
  json WaitJob(std::int64_t id, Pred pred, int seconds = 120) {
    const auto until = Clock::now() + std::chrono::seconds(seconds);
    json j = Job(id);
    while (!pred(j) && Clock::now() < until) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      j = Job(id);
    }
    EXPECT_TRUE(pred(j)) << j.dump();
    return j;
  }
  httplib::Result Cancel(std::int64_t id, const std::string& token) {
    return client_->Delete("/api/v1/jobs/" + std::to_string(id), Bearer(token));
  }

  fs::path dir_;
  std::unique_ptr<km::test::ServerProcess> server_;
  std::unique_ptr<httplib::Client> client_;
};

bool InReductionStudy(const json& j) {
  return j["status"] == "running" &&
         j["stage"].get<std::string>().find("reduction study") != std::string::npos;
}

bool Finished(const json& j) {
  return j["status"] != "queued" && j["status"] != "running";
}

TEST_F(JobsIntegration, TheOwnerCancelsALongJobAndTheWorkerRunsTheNextAtOnce) {
  const std::string alice = Token("engineer", "alice"), bob = Token("engineer", "bob");
  const std::string viewer = Token("viewer", "visitor");
  json request = CalibrationRequest();
  json reduction = request;
  reduction["reduction_study_min_tests"] = 1;
  const auto long_job = SubmitJob(alice, reduction);
  WaitJob(long_job, InReductionStudy);

  // Only its owner or an admin may cancel it; an unknown job is 404.
  for (const auto& token : {viewer, bob}) {
    auto r = Cancel(long_job, token);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 403) << r->body;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/problem+json");
  }
  EXPECT_EQ(Job(long_job)["status"], "running");
  EXPECT_EQ(Cancel(999, alice)->status, 404);

  const auto t0 = Clock::now();
  auto r = Cancel(long_job, alice);
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const json cancelled = json::parse(r->body);
  EXPECT_EQ(cancelled["status"], "cancelled");
  EXPECT_EQ(cancelled["error"], "cancelled by token 'alice' (id 2)");
  EXPECT_TRUE(cancelled["verdict"].is_null());

  // The only worker is free: the next job starts at once and finishes.
  const auto next = SubmitJob(bob, request);
  WaitJob(
      next, [](const json& j) { return j["status"] != "queued"; }, 10);
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(5)) << "the cancelled job held the worker";
  EXPECT_EQ(WaitJob(next, Finished)["status"], "done");
  const json after = Job(long_job);
  EXPECT_EQ(after["status"], "cancelled");
  EXPECT_EQ(after["stage"], "cancelled");
  EXPECT_FALSE(after.contains("result"));

  // Finished jobs cannot be cancelled (409), not even by an admin.
  for (const auto& [id, token] :
       {std::pair{long_job, alice}, std::pair{next, std::string(kJobsAdmin)}}) {
    auto again = Cancel(id, token);
    EXPECT_EQ(again->status, 409) << again->body;
  }
  // The audit log names the job cancelled.
  const json log = json::parse(client_->Get("/api/v1/audit-log", Bearer(kJobsAdmin))->body);
  bool logged = false;
  for (const auto& e : log["items"]) {
    logged = logged || (e["method"] == "DELETE" && e["status"] == 200 &&
                        e["subject"] == "job " + std::to_string(long_job));
  }
  EXPECT_TRUE(logged) << log.dump();
}

TEST_F(JobsIntegration, AnAdminCancelsAnyJobAndAQueuedJobNeverRuns) {
  const std::string alice = Token("engineer", "alice");
  json request = CalibrationRequest();
  request["reduction_study_min_tests"] = 1;
  const auto running = SubmitJob(alice, request);
  const auto queued = SubmitJob(alice, request);
  WaitJob(running, InReductionStudy);
  EXPECT_EQ(Job(queued)["status"], "queued");
  auto q = Cancel(queued, kJobsAdmin);
  ASSERT_EQ(q->status, 200) << q->body;
  EXPECT_EQ(json::parse(q->body)["status"], "cancelled");
  auto r = Cancel(running, kJobsAdmin);
  ASSERT_EQ(r->status, 200) << r->body;
  // Nothing else to run: the queued job stays cancelled, never started.
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const json never = Job(queued);
  EXPECT_EQ(never["status"], "cancelled");
  EXPECT_EQ(never["attempts"], 0);
  EXPECT_EQ(Job(running)["status"], "cancelled");
  const std::string metrics = client_->Get("/metrics", Bearer(kJobsAdmin))->body;
  EXPECT_NE(metrics.find("kinemetric_jobs{status=\"cancelled\"} 2"), std::string::npos) << metrics;
}

TEST_F(JobsIntegration, ARequestTheJobWouldRefuseIsRefusedBeforeItIsQueued) {
  json request = CalibrationRequest();
  request["reduction_study_min_tests"] = 3;
  request["effects"] = json::array({"gravity_deflection"});
  auto r = Submit(kJobsAdmin, request);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400) << r->body;
  EXPECT_EQ(json::parse(r->body)["field"], "reduction_study_min_tests");
  EXPECT_TRUE(json::parse(client_->Get("/api/v1/jobs", Bearer(kJobsAdmin))->body)["items"].empty());
}

}  // namespace
