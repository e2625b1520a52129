// The job queue shared by the instances on one database (server/jobs/jobs.h), on a real SQLite file
// opened by two connections as two instances would: every job runs once, a stopping instance
// gives its job back, a lapsed lease is taken over, a lost lease drops the outcome, a cancelled
// job stops at its next progress report (on this instance or another) and frees its worker.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include "analysis/core/errors.h"
#include "server/jobs/jobs.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server {
namespace {

using namespace std::chrono_literals;

std::int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

class JobQueueTest : public test::TempDirTest {
 protected:
  // Waits (up to 20 s) until the job's status is `status`.
  static JobRecord WaitStatus(Storage& st, JobId id, JobStatus status) {
    const auto until = std::chrono::steady_clock::now() + 20s;
    while (std::chrono::steady_clock::now() < until) {
      const auto j = st.GetJob(id);
      if (j && j->status == status) return *j;
      std::this_thread::sleep_for(5ms);
    }
    ADD_FAILURE() << "job " << id << " is not " << status;
    return st.GetJob(id).value_or(JobRecord{});
  }
  // A queue of instance `name` whose "count" jobs record which instance ran them; "slow" ones
  // report progress every millisecond until release_.
  std::unique_ptr<JobQueue> Queue(Storage& st, const std::string& name, int workers = 1,
                                  std::int64_t lease_ms = 30'000) {
    JobQueueOptions o;
    o.instance = name;
    o.workers = workers;
    o.lease_ms = lease_ms;
    o.poll_ms = 20;
    o.max_queued = 1000;
    JobKinds& kinds = kinds_.emplace_back();
    kinds.Add("count",
              {[this, name](const nlohmann::json& plan, const ProgressFn& p) {
                 if (plan.value("slow", false)) {
                   while (!release_) {
                     p(0.5, "waiting");
                     std::this_thread::sleep_for(1ms);
                   }
                 } else {
                   std::this_thread::sleep_for(std::chrono::milliseconds(plan.value("ms", 0)));
                 }
                 std::lock_guard lock(mu_);
                 runs_[plan.value("n", -1)].push_back(name);
                 return JobOutput{nlohmann::json{{"n", plan.value("n", -1)}, {"by", name}},
                                  plan.value("document", std::string())};
               },
               nullptr});
    return std::make_unique<JobQueue>(st, kinds, o);
  }
  std::deque<JobKinds> kinds_;  // outlive the queues of a test
  std::atomic<bool> release_{false};
  std::mutex mu_;
  std::map<int, std::vector<std::string>> runs_;
};

TEST_F(JobQueueTest, TwoInstancesOnOneDatabaseRunEveryJobOnceAndShareTheWork) {
  SqliteStorage db_a(Path("jobs.db")), db_b(Path("jobs.db"));
  auto a = Queue(db_a, "instance-a", 2);
  auto b = Queue(db_b, "instance-b", 2);
  std::vector<JobId> ids;
  for (int n = 0; n < 40; ++n) ids.push_back(a->Submit("count", {}, {{"n", n}, {"ms", 10}}));
  a->Start();
  b->Start();
  for (const auto id : ids) EXPECT_EQ(WaitStatus(db_a, id, JobStatus::kDone).attempts, 1);
  std::set<std::string> instances;
  for (int n = 0; n < 40; ++n) {
    ASSERT_EQ(runs_[n].size(), 1u) << "job " << n << " ran " << runs_[n].size() << " times";
    instances.insert(runs_[n][0]);
  }
  EXPECT_EQ(instances.size(), 2u) << "one instance ran every job";
}

TEST_F(JobQueueTest, AStoppingInstanceGivesItsRunningJobBackAndAnotherFinishesIt) {
  SqliteStorage db_a(Path("jobs.db")), db_b(Path("jobs.db"));
  auto a = Queue(db_a, "instance-a");
  a->Start();
  const auto id = a->Submit("count", {}, {{"n", 1}, {"slow", true}});
  const auto running = WaitStatus(db_a, id, JobStatus::kRunning);
  EXPECT_EQ(running.lease_owner, "instance-a");
  a->Stop();
  const auto back = db_a.GetJob(id);
  EXPECT_EQ(back->status, JobStatus::kQueued);
  EXPECT_EQ(back->lease_owner, "");
  EXPECT_EQ(back->attempts, 1);
  release_ = true;
  auto b = Queue(db_b, "instance-b");
  b->Start();
  const auto done = WaitStatus(db_b, id, JobStatus::kDone);
  EXPECT_EQ(done.attempts, 2);
  EXPECT_EQ(done.lease_owner, "instance-b");  // the instance that ran it
  EXPECT_EQ(nlohmann::json::parse(done.result_json)["by"], "instance-b");
}

TEST_F(JobQueueTest, AJobOfAnInstanceThatDiedIsTakenOverWhenItsLeaseLapses) {
  SqliteStorage db(Path("jobs.db"));
  auto b = Queue(db, "instance-b");
  const auto id = b->Submit("count", {}, {{"n", 5}});
  // An instance takes the job and dies: its lease of 300 ms is never renewed.
  const auto claimed = db.ClaimJob("instance-dead", NowMs(), 300, 3, "abandoned");
  ASSERT_TRUE(claimed);
  EXPECT_EQ(claimed->id, id);
  const auto t0 = std::chrono::steady_clock::now();
  b->Start();
  const auto done = WaitStatus(db, id, JobStatus::kDone);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 200ms) << "taken before the lease lapsed";
  EXPECT_EQ(done.attempts, 2);
  EXPECT_EQ(nlohmann::json::parse(done.result_json)["by"], "instance-b");
}

TEST_F(JobQueueTest, ALeaseRenewedByTheHeartbeatIsNotTakenOver) {
  SqliteStorage db_a(Path("jobs.db")), db_b(Path("jobs.db"));
  auto a = Queue(db_a, "instance-a", 1, 300);
  a->Start();
  const auto id = a->Submit("count", {}, {{"n", 2}, {"slow", true}});
  WaitStatus(db_a, id, JobStatus::kRunning);
  auto b = Queue(db_b, "instance-b", 1, 300);
  b->Start();
  std::this_thread::sleep_for(1200ms);  // four leases
  release_ = true;
  const auto done = WaitStatus(db_a, id, JobStatus::kDone);
  EXPECT_EQ(done.attempts, 1);
  EXPECT_EQ(nlohmann::json::parse(done.result_json)["by"], "instance-a");
}

TEST_F(JobQueueTest, AnInstanceThatLostItsLeaseDropsItsOutcome) {
  SqliteStorage db(Path("jobs.db"));
  auto a = Queue(db, "instance-a");
  a->Start();
  const auto id = a->Submit("count", {}, {{"n", 3}, {"slow", true}});
  WaitStatus(db, id, JobStatus::kRunning);
  // Another instance takes the job over, as when instance-a's lease lapsed (its clock two
  // minutes ahead).
  const auto other = db.ClaimJob("instance-other", NowMs() + 120'000, 600'000, 3, "abandoned");
  ASSERT_TRUE(other);
  EXPECT_EQ(other->attempts, 2);
  std::this_thread::sleep_for(100ms);
  release_ = true;
  a->Stop();
  const auto j = db.GetJob(id);
  EXPECT_EQ(j->status, JobStatus::kRunning);
  EXPECT_EQ(j->lease_owner, "instance-other");
  EXPECT_EQ(j->result_json, "");
  EXPECT_FALSE(db.FinishJob(*j, "instance-a"));
}

TEST_F(JobQueueTest, AJobWhoseInstancesKeepDyingFailsAfterTheLastAttempt) {
  SqliteStorage db(Path("jobs.db"));
  const auto id = db.QueueJob(NewJob{"count", "{}", R"({"n":9})"});
  std::int64_t now = NowMs();
  for (int attempt = 1; attempt <= 3; ++attempt) {
    const auto j = db.ClaimJob("instance-" + std::to_string(attempt), now, 100, 3, "gave up");
    ASSERT_TRUE(j) << attempt;
    EXPECT_EQ(j->attempts, attempt);
    EXPECT_FALSE(db.ClaimJob("instance-x", now + 50, 100, 3, "gave up")) << "lease still holds";
    now += 200;  // the lease lapses
  }
  EXPECT_FALSE(db.ClaimJob("instance-4", now, 100, 3, "gave up"));
  const auto j = db.GetJob(id);
  EXPECT_EQ(j->status, JobStatus::kFailed);
  EXPECT_EQ(j->error, "gave up");
}

TEST_F(JobQueueTest, TheQueueBoundCountsTheJobsOfEveryInstance) {
  SqliteStorage db_a(Path("jobs.db")), db_b(Path("jobs.db"));
  JobQueueOptions o;
  o.max_queued = 3;
  const JobKinds kinds;
  JobQueue a(db_a, kinds, o), b(db_b, kinds, o);  // not started: jobs stay queued
  a.Submit("count", {}, {{"n", 1}});
  b.Submit("count", {}, {{"n", 2}});
  a.Submit("count", {}, {{"n", 3}});
  EXPECT_THROW(b.Submit("count", {}, {{"n", 4}}), Unavailable);
}

TEST_F(JobQueueTest, AJobOfAnUnknownKindOrWithoutPlanFailsWithTheReason) {
  SqliteStorage db(Path("jobs.db"));
  auto a = Queue(db, "instance-a");
  const auto other = db.QueueJob(NewJob{"telepathy", "{}", "{}"});
  const auto old = db.CreateJob("count", "");  // as an earlier version stored it
  a->Start();
  EXPECT_NE(WaitStatus(db, other, JobStatus::kFailed).error.find("kind 'telepathy'"),
            std::string::npos);
  EXPECT_NE(WaitStatus(db, old, JobStatus::kFailed).error.find("submit it again"),
            std::string::npos);
}

// What a runner produced is stored as it is: the result, and the machine document byte for byte
// (spacing, digits, key order and line ends as written, not as a JSON writer would redo them).
TEST_F(JobQueueTest, TheRunnersMachineDocumentIsStoredAsWritten) {
  SqliteStorage db(Path("jobs.db"));
  auto a = Queue(db, "instance-a");
  a->Start();
  const std::string document = "{\"z\": 1.50,\r\n \"a\": [1e-3 ,2]}\n\n";
  const auto id = a->Submit("count", {}, {{"n", 5}, {"document", document}});
  const JobRecord done = WaitStatus(db, id, JobStatus::kDone);
  EXPECT_EQ(done.machine_document, document);
  EXPECT_EQ(nlohmann::json::parse(done.result_json)["n"], 5);
  const auto plain = a->Submit("count", {}, {{"n", 6}});
  EXPECT_EQ(WaitStatus(db, plain, JobStatus::kDone).machine_document, "");
}

// A kind's judge, registered beside its runner, gives the verdict in the job's answer; the queue
// itself judges nothing.
TEST(JobKindsTest, TheVerdictIsThatOfTheKindsJudge) {
  JobKinds kinds;
  kinds.Add("strict", {nullptr, [](const nlohmann::json& r, JobFindings& f) {
                         if (r.value("rms_um", 0.0) > 1.0) f.Warn("rms " + VerdictNumber(1.25));
                       }});
  JobRecord job;
  job.id = JobId(9);
  job.kind = "strict";
  job.status = JobStatus::kDone;
  job.result_json = R"({"rms_um":2})";
  const auto j = kinds.Json(job);
  EXPECT_EQ(j["verdict"], "warning");
  EXPECT_EQ(j["verdict_reasons"], nlohmann::json::array({"rms 1.25"}));
  EXPECT_EQ(kinds.Verdict(job).verdict, "warning");
  job.kind = "lenient";  // not registered: done is ok
  EXPECT_EQ(kinds.Json(job)["verdict"], "ok");
  job.result_json.clear();  // done without a result fails whatever the kind
  EXPECT_EQ(kinds.Verdict(job).verdict, "failed");
}

TEST_F(JobQueueTest, ACancelledRunningJobStopsAtItsNextReportAndFreesTheWorker) {
  SqliteStorage db(Path("jobs.db"));
  auto a = Queue(db, "instance-a");  // one worker
  a->Start();
  const auto slow = a->Submit("count", {}, {{"n", 1}, {"slow", true}}, TokenId(7));
  EXPECT_EQ(WaitStatus(db, slow, JobStatus::kRunning).owner_token_id, TokenId(7));
  const auto next = a->Submit("count", {}, {{"n", 2}});
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(a->Cancel(slow, "cancelled by the test"));
  const auto cancelled = *db.GetJob(slow);
  EXPECT_EQ(cancelled.status, JobStatus::kCancelled);
  EXPECT_EQ(cancelled.stage, "cancelled");
  EXPECT_EQ(cancelled.error, "cancelled by the test");
  // The worker is free: the next job runs at once.
  WaitStatus(db, next, JobStatus::kDone);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 5s);
  EXPECT_EQ(db.GetJob(slow)->status, JobStatus::kCancelled);  // never finished afterwards
  EXPECT_TRUE(runs_[1].empty());
  EXPECT_FALSE(a->Cancel(slow, "again"));     // cancelled already
  EXPECT_FALSE(a->Cancel(next, "too late"));  // done
  EXPECT_EQ(db.GetJob(next)->status, JobStatus::kDone);
}

TEST_F(JobQueueTest, AJobCancelledThroughAnotherInstanceStopsWhereItRuns) {
  SqliteStorage db_a(Path("jobs.db")), db_b(Path("jobs.db"));
  auto a = Queue(db_a, "instance-a");
  auto b = Queue(db_b, "instance-b", 0);  // runs no jobs: answers the API
  a->Start();
  b->Start();
  const auto slow = b->Submit("count", {}, {{"n", 1}, {"slow", true}});
  WaitStatus(db_b, slow, JobStatus::kRunning);
  ASSERT_TRUE(b->Cancel(slow, "cancelled elsewhere"));
  const auto next = b->Submit("count", {}, {{"n", 2}});
  EXPECT_EQ(nlohmann::json::parse(WaitStatus(db_b, next, JobStatus::kDone).result_json)["by"],
            "instance-a");
  EXPECT_EQ(db_a.GetJob(slow)->status, JobStatus::kCancelled);
  EXPECT_TRUE(runs_[1].empty());
}

TEST_F(JobQueueTest, AQueuedJobCancelledIsNeverRun) {
  SqliteStorage db(Path("jobs.db"));
  auto a = Queue(db, "instance-a");
  const auto id = a->Submit("count", {}, {{"n", 3}});
  ASSERT_TRUE(a->Cancel(id, "not wanted"));
  const auto after = a->Submit("count", {}, {{"n", 4}});
  a->Start();
  WaitStatus(db, after, JobStatus::kDone);
  EXPECT_EQ(db.GetJob(id)->status, JobStatus::kCancelled);
  EXPECT_TRUE(runs_[3].empty());
}

}  // namespace
}  // namespace km::server
