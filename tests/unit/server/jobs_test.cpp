// The job worker survives storage errors: a failed status, progress or result update is
// reported with the job id, the job is marked failed when the storage allows it, and later
// jobs still run.
#include "server/jobs.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "tests/unit/server/flaky_storage.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server {
namespace {

using testing::FlakyStorage;

class JobStorageErrors : public testing::TempDirTest {
 protected:
  // Waits until the job is done or failed (or 20 s have passed).
  static JobRecord WaitFinished(Storage& st, std::int64_t id) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < until) {
      const auto j = st.GetJob(id);
      if (j && (j->status == "done" || j->status == "failed")) return *j;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ADD_FAILURE() << "job " << id << " did not finish";
    return st.GetJob(id).value_or(JobRecord{});
  }
  static JobQueue::Work Answer(int v) {
    return [v](const JobQueue::Progress& progress) {
      progress(0.5, "half way");
      return nlohmann::json{{"answer", v}};
    };
  }
};

TEST_F(JobStorageErrors, EveryUpdateOfAJobFailingLeavesTheWorkerAlive) {
  FlakyStorage st(Path("jobs.db"));
  JobQueue q(st);
  st.FailUpdatesWhen([](const JobRecord& j) { return j.id == 1; });
  std::atomic<bool> ran{false};
  const auto first = q.Submit("test", {}, [&](const JobQueue::Progress& progress) {
    progress(0.5, "half way");
    ran = true;
    return nlohmann::json{{"answer", 1}};
  });
  ASSERT_EQ(first, 1);
  const auto second = q.Submit("test", {}, Answer(2));
  const auto j2 = WaitFinished(st, second);
  EXPECT_EQ(j2.status, "done");
  EXPECT_NE(j2.result_json.find("\"answer\":2"), std::string::npos) << j2.result_json;
  EXPECT_TRUE(ran.load());
  EXPECT_GE(st.failed_updates(), 3);  // running, progress, done, failed
  // Nothing could be written for job 1: it stays queued in the database (the next start marks
  // it failed), and the process goes on.
  EXPECT_EQ(st.GetJob(first)->status, "queued");
}

TEST_F(JobStorageErrors, AResultThatCannotBeStoredMarksTheJobFailed) {
  FlakyStorage st(Path("jobs.db"));
  JobQueue q(st);
  st.FailUpdatesWhen([](const JobRecord& j) { return j.status == "done"; });
  const auto id = q.Submit("test", {}, Answer(7));
  const auto j = WaitFinished(st, id);
  EXPECT_EQ(j.status, "failed");
  EXPECT_NE(j.error.find("could not be stored"), std::string::npos) << j.error;
  EXPECT_NE(j.error.find("disk I/O error"), std::string::npos) << j.error;
  st.FailUpdatesWhen(nullptr);
  EXPECT_EQ(WaitFinished(st, q.Submit("test", {}, Answer(8))).status, "done");
}

TEST_F(JobStorageErrors, StatusAndProgressUpdatesFailingDoNotStopTheWork) {
  FlakyStorage st(Path("jobs.db"));
  JobQueue q(st);
  st.FailUpdatesWhen([](const JobRecord& j) { return j.status == "running"; });
  const auto id = q.Submit("test", {}, Answer(3));
  const auto j = WaitFinished(st, id);
  EXPECT_EQ(j.status, "done");
  EXPECT_NE(j.result_json.find("\"answer\":3"), std::string::npos);
  EXPECT_GE(st.failed_updates(), 2);
}

TEST_F(JobStorageErrors, AJobThatThrowsWhileItsFailureCannotBeStoredLeavesTheWorkerAlive) {
  FlakyStorage st(Path("jobs.db"));
  JobQueue q(st);
  st.FailUpdatesWhen([](const JobRecord& j) { return j.id == 1 && j.status == "failed"; });
  const auto bad = q.Submit("test", {}, [](const JobQueue::Progress&) -> nlohmann::json {
    throw std::runtime_error("the solve diverged");
  });
  const auto good = q.Submit("test", {}, Answer(4));
  EXPECT_EQ(WaitFinished(st, good).status, "done");
  EXPECT_EQ(st.GetJob(bad)->status, "running");
}

TEST_F(JobStorageErrors, StoppingWithQueuedJobsAndAFailingStorageDoesNotTerminate) {
  FlakyStorage st(Path("jobs.db"));
  std::atomic<bool> release{false};
  std::thread releaser;
  {
    JobQueue q(st);
    q.Submit("test", {}, [&](const JobQueue::Progress&) {
      while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      return nlohmann::json{};
    });
    for (int k = 0; k < 3; ++k) q.Submit("test", {}, Answer(k));
    st.FailUpdatesWhen([](const JobRecord&) { return true; });
    releaser = std::thread([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      release = true;
    });
  }  // the destructor fails the queued jobs while every update throws
  releaser.join();
  EXPECT_GE(st.failed_updates(), 4);
}

}  // namespace
}  // namespace km::server
