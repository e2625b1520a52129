// The job queue and the claim of scheduled audit runs on both storage backends: the oldest job
// first, leases taken over when they lapse, failed after the last attempt, a lost owner's
// progress and outcome refused, jobs given back, queued and running jobs cancelled (never
// claimed again, their owner's progress and outcome refused); two storages (two instances) claiming
// from several threads at once take every job exactly once.
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "tests/unit/server/storage_backends.h"

namespace km::server {
namespace {

using test::Backends;

const std::string kAbandoned = "the instance running it stopped";

NewJob Job(int n) {
  return NewJob{"calibration", "{\"n\":" + std::to_string(n) + "}",
                "{\"plan\":" + std::to_string(n) + "}", std::nullopt};
}

TEST_P(Backends, JobsAreClaimedOldestFirstWithTheirPlan) {
  auto s = Open();
  for (int n = 1; n <= 3; ++n) EXPECT_EQ(s->QueueJob(Job(n)).value(), n);
  const auto j = s->ClaimJob("a", 1000, 500, 3, kAbandoned);
  ASSERT_TRUE(j);
  EXPECT_EQ(j->id.value(), 1);
  EXPECT_EQ(j->status, JobStatus::kRunning);
  EXPECT_EQ(j->stage, "started");
  EXPECT_EQ(j->progress, 0.0);
  EXPECT_EQ(j->plan_json, R"({"plan":1})");
  EXPECT_EQ(j->request_json, R"({"n":1})");
  EXPECT_EQ(j->lease_owner, "a");
  EXPECT_EQ(j->lease_until_ms, 1500);
  EXPECT_EQ(j->attempts, 1);
  const auto stored = *s->GetJob(JobId(1));
  EXPECT_EQ(stored.status, JobStatus::kRunning);
  EXPECT_EQ(stored.lease_owner, "a");
  EXPECT_EQ(stored.lease_until_ms, 1500);
  EXPECT_EQ(stored.attempts, 1);
  EXPECT_EQ(stored.plan_json, R"({"plan":1})");
  EXPECT_EQ(s->ClaimJob("a", 1000, 500, 3, kAbandoned)->id.value(), 2);
  EXPECT_EQ(s->ClaimJob("b", 1000, 500, 3, kAbandoned)->id.value(), 3);
  EXPECT_FALSE(s->ClaimJob("b", 1000, 500, 3, kAbandoned));
  // CreateJob queues a job whose plan is its request.
  const auto id = s->CreateJob("discovery", R"({"x":1})");
  EXPECT_EQ(s->GetJob(id)->plan_json, R"({"x":1})");
  EXPECT_EQ(s->GetJob(id)->status, JobStatus::kQueued);
}

TEST_P(Backends, ALapsedLeaseIsTakenOverAndTheLastAttemptFails) {
  auto s = Open();
  s->QueueJob(Job(1));
  ASSERT_EQ(s->ClaimJob("a", 1000, 500, 3, kAbandoned)->lease_until_ms, 1500);
  EXPECT_FALSE(s->ClaimJob("b", 1500, 500, 3, kAbandoned));  // until 1500 inclusive: a's
  const auto b = s->ClaimJob("b", 1501, 1000, 3, kAbandoned);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->id.value(), 1);
  EXPECT_EQ(b->attempts, 2);
  EXPECT_EQ(b->lease_owner, "b");
  EXPECT_EQ(b->lease_until_ms, 2501);
  // a lost it: its progress and its outcome are refused, nothing written.
  EXPECT_FALSE(s->RenewJob(JobId(1), "a", 0.9, "late", 9000));
  JobRecord done = *b;
  done.status = JobStatus::kDone;
  done.progress = 1.0;
  done.result_json = R"({"from":"a"})";
  EXPECT_FALSE(s->FinishJob(done, "a"));
  EXPECT_EQ(s->GetJob(JobId(1))->stage, "started");
  EXPECT_EQ(s->GetJob(JobId(1))->lease_until_ms, 2501);
  EXPECT_TRUE(s->RenewJob(JobId(1), "b", 0.5, "fit", 4000));
  auto now = *s->GetJob(JobId(1));
  EXPECT_EQ(now.progress, 0.5);
  EXPECT_EQ(now.stage, "fit");
  EXPECT_EQ(now.lease_until_ms, 4000);
  EXPECT_FALSE(s->ClaimJob("c", 4000, 1000, 3, kAbandoned));
  EXPECT_EQ(s->ClaimJob("c", 4001, 1000, 3, kAbandoned)->attempts, 3);
  // The third start lapsed too: failed, not started a fourth time.
  EXPECT_FALSE(s->ClaimJob("d", 9000, 1000, 3, kAbandoned));
  now = *s->GetJob(JobId(1));
  EXPECT_EQ(now.status, JobStatus::kFailed);
  EXPECT_EQ(now.error, kAbandoned);
  EXPECT_EQ(now.lease_owner, "");
  EXPECT_EQ(now.lease_until_ms, 0);
  EXPECT_EQ(now.attempts, 3);
  EXPECT_FALSE(s->RenewJob(JobId(1), "c", 0.1, "x", 99999));
}

TEST_P(Backends, TheOwnerFinishesItsJobOnce) {
  auto s = Open();
  s->QueueJob(Job(1));
  JobRecord j = *s->ClaimJob("a", 0, 100, 3, kAbandoned);
  j.status = JobStatus::kDone;
  j.progress = 1.0;
  j.stage = "done";
  j.result_json = R"({"r":1})";
  // The machine document is kept byte for byte (spacing, digits and order as written).
  const std::string document = "{\n  \"z\": 1.50,\n  \"a\": \"é\"\t}\r\n";
  j.machine_document = document;
  EXPECT_TRUE(s->FinishJob(j, "a"));
  const auto stored = *s->GetJob(JobId(1));
  EXPECT_EQ(stored.status, JobStatus::kDone);
  EXPECT_EQ(stored.result_json, R"({"r":1})");
  EXPECT_EQ(stored.machine_document, document);
  EXPECT_EQ(s->ListJobs(5).at(0).machine_document, document);
  EXPECT_EQ(stored.progress, 1.0);
  EXPECT_EQ(stored.lease_owner, "a");  // the instance that ran it
  EXPECT_EQ(stored.lease_until_ms, 0);
  EXPECT_FALSE(s->FinishJob(j, "a"));                             // no longer running
  EXPECT_FALSE(s->ClaimJob("b", 1'000'000, 100, 3, kAbandoned));  // done jobs are not taken
}

TEST_P(Backends, AStoppingInstanceGivesItsJobsBack) {
  auto s = Open();
  for (int n = 1; n <= 3; ++n) s->QueueJob(Job(n));
  s->ClaimJob("a", 0, 100, 3, kAbandoned);
  s->ClaimJob("b", 0, 100, 3, kAbandoned);
  s->ClaimJob("a", 0, 100, 3, kAbandoned);
  EXPECT_EQ(s->ReleaseJobs("a"), 2);
  EXPECT_EQ(s->ReleaseJobs("a"), 0);
  const auto one = *s->GetJob(JobId(1));
  EXPECT_EQ(one.status, JobStatus::kQueued);
  EXPECT_EQ(one.stage, "waiting for an instance");
  EXPECT_EQ(one.lease_owner, "");
  EXPECT_EQ(one.lease_until_ms, 0);
  EXPECT_EQ(one.attempts, 1);  // kept
  EXPECT_EQ(s->GetJob(JobId(2))->lease_owner, "b");
  const auto again = s->ClaimJob("c", 10, 100, 3, kAbandoned);
  EXPECT_EQ(again->id.value(), 1);
  EXPECT_EQ(again->attempts, 2);
  EXPECT_EQ(s->ClaimJob("c", 10, 100, 3, kAbandoned)->id.value(), 3);
  EXPECT_EQ(s->CountJobsByStatus(), (std::map<std::string, std::int64_t>{{"running", 3}}));
}

TEST_P(Backends, QueuedAndRunningJobsAreCancelledAndNeverTakenAgain) {
  auto s = Open();
  NewJob owned = Job(1);
  owned.owner_token_id = TokenId(42);
  s->QueueJob(owned);
  s->QueueJob(Job(2));
  s->QueueJob(Job(3));
  EXPECT_EQ(s->GetJob(JobId(1))->owner_token_id, TokenId(42));
  EXPECT_FALSE(s->GetJob(JobId(2))->owner_token_id);
  JobRecord running = *s->ClaimJob("a", 0, 100, 3, kAbandoned);
  ASSERT_EQ(running.id.value(), 1);
  EXPECT_EQ(running.owner_token_id, TokenId(42));
  EXPECT_TRUE(s->CancelJob(JobId(1), "cancelled by token 'x' (id 42)"));
  EXPECT_TRUE(s->CancelJob(JobId(2), "not wanted"));
  const auto one = *s->GetJob(JobId(1));
  EXPECT_EQ(one.status, JobStatus::kCancelled);
  EXPECT_EQ(one.stage, "cancelled");
  EXPECT_EQ(one.error, "cancelled by token 'x' (id 42)");
  EXPECT_EQ(one.lease_until_ms, 0);
  EXPECT_EQ(one.owner_token_id, TokenId(42));
  // The instance running it learns at its next report; its outcome is refused.
  EXPECT_FALSE(s->RenewJob(JobId(1), "a", 0.5, "x", 1000));
  running.status = JobStatus::kDone;
  EXPECT_FALSE(s->FinishJob(running, "a"));
  EXPECT_EQ(s->GetJob(JobId(1))->status, JobStatus::kCancelled);
  EXPECT_EQ(s->ReleaseJobs("a"), 0);
  // Never claimed again, also long after any lease; a second cancel changes nothing.
  JobRecord three = *s->ClaimJob("b", 1'000'000, 100, 3, kAbandoned);
  EXPECT_EQ(three.id.value(), 3);
  three.status = JobStatus::kDone;
  EXPECT_TRUE(s->FinishJob(three, "b"));
  EXPECT_FALSE(s->ClaimJob("b", 2'000'000, 100, 3, kAbandoned));
  EXPECT_FALSE(s->CancelJob(JobId(1), "again"));
  EXPECT_EQ(s->GetJob(JobId(1))->error, "cancelled by token 'x' (id 42)");
  EXPECT_FALSE(s->CancelJob(JobId(99), "no such job"));
  EXPECT_FALSE(s->CancelJob(JobId(3), "finished"));  // done jobs stay done
  EXPECT_EQ(s->CountJobsByStatus(),
            (std::map<std::string, std::int64_t>{{"cancelled", 2}, {"done", 1}}));
  EXPECT_EQ(s->FailInterruptedJobs("restart"), 0);
}

TEST_P(Backends, TwoInstancesClaimingFromManyThreadsTakeEveryJobOnce) {
  auto a = Open();
  auto b = Open();
  constexpr int kJobs = 40;
  for (int n = 1; n <= kJobs; ++n) a->QueueJob(Job(n));
  std::mutex mu;
  std::vector<std::int64_t> taken;
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      Storage& s = t % 2 ? *a : *b;
      const std::string owner = "worker " + std::to_string(t);
      while (auto j = s.ClaimJob(owner, 1000, 60'000, 3, kAbandoned)) {
        {
          std::lock_guard lock(mu);
          taken.push_back(j->id.value());
        }
        j->status = JobStatus::kDone;
        j->result_json = "{}";
        EXPECT_TRUE(s.FinishJob(*j, owner)) << j->id;
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(taken.size(), static_cast<std::size_t>(kJobs));
  EXPECT_EQ(std::set<std::int64_t>(taken.begin(), taken.end()).size(),
            static_cast<std::size_t>(kJobs));
  EXPECT_EQ(a->CountJobsByStatus(), (std::map<std::string, std::int64_t>{{"done", kJobs}}));
  for (const auto& j : b->ListJobs(kJobs)) EXPECT_EQ(j.attempts, 1) << j.id;
}

TEST_P(Backends, AScheduledAuditRunIsClaimedByOneInstance) {
  auto a = Open();
  auto b = Open();
  const std::string due = "2026-06-02T06:00:00Z";
  a->PutAuditConfig({"vmc", "daily 06:00", "[]", "", std::nullopt, due});
  std::atomic<int> won{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      Storage& s = t % 2 ? *a : *b;
      if (s.ClaimAuditRun("vmc", due, "2026-06-02T06:00:0" + std::to_string(t) + "Z",
                          std::string("2026-06-03T06:00:00Z"))) {
        ++won;
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(won.load(), 1);
  const auto c = *a->GetAuditConfig("vmc");
  EXPECT_EQ(c.next_run_at, "2026-06-03T06:00:00Z");
  ASSERT_TRUE(c.last_run_at);
  EXPECT_EQ(c.last_run_at->substr(0, 18), "2026-06-02T06:00:0");
  EXPECT_FALSE(a->ClaimAuditRun("vmc", due, "x", std::nullopt));
  EXPECT_FALSE(a->ClaimAuditRun("other", due, "x", std::nullopt));
  EXPECT_TRUE(
      a->ClaimAuditRun("vmc", "2026-06-03T06:00:00Z", "2026-06-03T06:00:01Z", std::nullopt));
  EXPECT_FALSE(a->GetAuditConfig("vmc")->next_run_at);
}

}  // namespace
}  // namespace km::server
