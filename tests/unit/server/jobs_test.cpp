// The job worker survives storage errors: a failed status, progress or result update is
// reported with the job id, the job is marked failed when the storage allows it, and later
// jobs still run.
#include "server/jobs/jobs.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>

#include "analysis/core/errors.h"
#include "server/jobs/study_service.h"
#include "tests/unit/server/flaky_storage.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server {
namespace {

using test::FlakyStorage;

// The verdict of the studies' judges (registered beside their runners) on a job of `kind`.
JobVerdict JudgeJob(const std::string& kind, JobStatus status, const nlohmann::json& result,
                    const std::string& error) {
  return JudgeJobOutcome(kind == kCalibrationJob ? JudgeCalibrationResult : JudgeDiscoveryResult,
                         status, result, error);
}

class JobStorageErrors : public test::TempDirTest {
 protected:
  // Waits until the job is done or failed (or 20 s have passed).
  static JobRecord WaitFinished(Storage& st, JobId id) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < until) {
      const auto j = st.GetJob(id);
      if (j && (j->status == JobStatus::kDone || j->status == JobStatus::kFailed)) return *j;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ADD_FAILURE() << "job " << id << " did not finish";
    return st.GetJob(id).value_or(JobRecord{});
  }
  // A queue whose "test" jobs answer their plan's value after a progress report; a plan with
  // "throw" fails, one with "wait" waits until release is set.
  std::unique_ptr<JobQueue> Queue(Storage& st) {
    kinds_.Add("test", {[this](const nlohmann::json& plan, const ProgressFn& progress) {
                          if (plan.contains("throw"))
                            throw std::runtime_error("the solve diverged");
                          if (plan.contains("refuse"))
                            throw InvalidInput("plan.json", 3, "tests", "no DBB test");
                          if (plan.contains("wait")) {
                            while (!release_)
                              std::this_thread::sleep_for(std::chrono::milliseconds(1));
                          }
                          progress(0.5, "half way");
                          ran_.fetch_add(1);
                          return JobOutput{nlohmann::json{{"answer", plan.value("v", 0)}}, ""};
                        },
                        nullptr});
    auto q = std::make_unique<JobQueue>(st, kinds_);
    q->Start();
    return q;
  }
  JobKinds kinds_;  // outlives the queues of a test
  static JobId Submit(JobQueue& q, const nlohmann::json& plan) {
    return q.Submit("test", nlohmann::json::object(), plan);
  }
  std::atomic<bool> release_{false};
  std::atomic<int> ran_{0};
};

TEST_F(JobStorageErrors, EveryUpdateOfAJobFailingLeavesTheWorkerAlive) {
  FlakyStorage st(Path("jobs.db"));
  st.FailUpdatesWhen([](const JobRecord& j) { return j.id == JobId(1); });
  auto q = Queue(st);
  const auto first = Submit(*q, {{"v", 1}});
  ASSERT_EQ(first, JobId(1));
  const auto second = Submit(*q, {{"v", 2}});
  const auto j2 = WaitFinished(st, second);
  EXPECT_EQ(j2.status, JobStatus::kDone);
  EXPECT_NE(j2.result_json.find("\"answer\":2"), std::string::npos) << j2.result_json;
  EXPECT_EQ(ran_.load(), 2);
  EXPECT_GE(st.failed_updates(), 2);  // progress, done
  // Nothing could be written for job 1 after its claim: it stays running under a lease that
  // lapses (then another start runs it), and the process goes on.
  EXPECT_EQ(st.GetJob(first)->status, JobStatus::kRunning);
}

TEST_F(JobStorageErrors, AResultThatCannotBeStoredMarksTheJobFailed) {
  FlakyStorage st(Path("jobs.db"));
  st.FailUpdatesWhen([](const JobRecord& j) { return j.status == JobStatus::kDone; });
  auto q = Queue(st);
  const auto id = Submit(*q, {{"v", 7}});
  const auto j = WaitFinished(st, id);
  EXPECT_EQ(j.status, JobStatus::kFailed);
  EXPECT_NE(j.error.find("could not be stored"), std::string::npos) << j.error;
  EXPECT_NE(j.error.find("disk I/O error"), std::string::npos) << j.error;
  st.FailUpdatesWhen(nullptr);
  EXPECT_EQ(WaitFinished(st, Submit(*q, {{"v", 8}})).status, JobStatus::kDone);
}

TEST_F(JobStorageErrors, StatusAndProgressUpdatesFailingDoNotStopTheWork) {
  FlakyStorage st(Path("jobs.db"));
  st.FailUpdatesWhen([](const JobRecord& j) { return j.status == JobStatus::kRunning; });
  auto q = Queue(st);
  const auto j = WaitFinished(st, Submit(*q, {{"v", 3}}));
  EXPECT_EQ(j.status, JobStatus::kDone);
  EXPECT_NE(j.result_json.find("\"answer\":3"), std::string::npos);
  EXPECT_GE(st.failed_updates(), 1);
}

TEST_F(JobStorageErrors, AJobThatThrowsWhileItsFailureCannotBeStoredLeavesTheWorkerAlive) {
  FlakyStorage st(Path("jobs.db"));
  st.FailUpdatesWhen(
      [](const JobRecord& j) { return j.id == JobId(1) && j.status == JobStatus::kFailed; });
  auto q = Queue(st);
  const auto bad = Submit(*q, {{"throw", true}});
  const auto good = Submit(*q, {{"v", 4}});
  EXPECT_EQ(WaitFinished(st, good).status, JobStatus::kDone);
  EXPECT_EQ(st.GetJob(bad)->status, JobStatus::kRunning);
}

// A job's error is for its user: the product's own errors (bad input, not observable, not
// converged) keep their message; anything else is named an internal error, logged with the id.
TEST_F(JobStorageErrors, AJobFailsWithTheUsersMessageOrAsAnInternalError) {
  SqliteStorage st(Path("jobs.db"));
  auto q = Queue(st);
  const auto refused = WaitFinished(st, Submit(*q, {{"refuse", true}}));
  EXPECT_EQ(refused.status, JobStatus::kFailed);
  EXPECT_EQ(refused.error, InvalidInput("plan.json", 3, "tests", "no DBB test").what());
  const auto id = Submit(*q, {{"throw", true}});
  const auto internal = WaitFinished(st, id);
  EXPECT_EQ(internal.status, JobStatus::kFailed);
  EXPECT_EQ(internal.error, "the job failed with an internal error (logged by the server as job " +
                                to_string(id) + ")");
}

TEST_F(JobStorageErrors, StoppingWithQueuedJobsAndAFailingStorageDoesNotTerminate) {
  FlakyStorage st(Path("jobs.db"));
  std::thread releaser;
  {
    auto q = Queue(st);
    Submit(*q, {{"wait", true}});
    for (int k = 0; k < 3; ++k) Submit(*q, {{"v", k}});
    st.FailUpdatesWhen([](const JobRecord&) { return true; });
    releaser = std::thread([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      release_ = true;
    });
  }  // the stop interrupts the running job while every write throws
  releaser.join();
  EXPECT_GE(st.failed_updates(), 0);
  // Nothing is lost: the interrupted job and the queued ones wait for the next start.
  for (std::int64_t id = 1; id <= 4; ++id)
    EXPECT_EQ(st.GetJob(JobId(id))->status, JobStatus::kQueued) << id;
}

// The verdict on a finished job: a calibration that is ill-conditioned, not converged or
// under-determined is not "ok", and the reasons name what is wrong with the figures.
nlohmann::json GoodCalibration() {
  return {{"method", "absolute"},
          {"condition_number", 1623.1},
          {"converged", true},
          {"iterations", 6},
          {"fixed_parameters", nlohmann::json::array()},
          {"parameter_uncertainty_um",
           {{"strut_offset_um", {0.5, 0.6, 0.4, 0.7, 0.5, 0.6}},
            {"base_joint_offset_um", {{1.0, 4.8, 2.0}, {1, 1, 1}}}}},
          {"tests", nlohmann::json::array({{{"test_id", "a"}}, {{"test_id", "b"}}})}};
}

TEST(JobVerdict, AWellDeterminedCalibrationIsOk) {
  const auto v = JudgeJob("hexapod_calibration", JobStatus::kDone, GoodCalibration(), "");
  EXPECT_EQ(v.verdict, "ok");
  EXPECT_TRUE(v.reasons.empty());
  // Centre-corrected fixes the 6 rigid motions of the base: that alone is no warning.
  auto cc = GoodCalibration();
  cc["method"] = "centre_corrected";
  cc["fixed_parameters"] = {"a", "b", "c", "d", "e", "f"};
  EXPECT_EQ(JudgeJob("hexapod_calibration", JobStatus::kDone, cc, "").verdict, "ok");
}

TEST(JobVerdict, OneTestCalibrationIsAWarningWithEveryReason) {
  // What one DBB test gives (measured with the reference hexapod): not converged, condition
  // number 178 483, uncertainties of thousands of µm, 15 parameters fixed.
  auto r = GoodCalibration();
  r["condition_number"] = 178482.9;
  r["converged"] = false;
  r["iterations"] = 50;
  r["parameter_uncertainty_um"]["strut_offset_um"] = {1576.3, 853.3,  2677.5,
                                                      1698.6, 1073.2, 1766.4};
  r["fixed_parameters"] = nlohmann::json(std::vector<std::string>(15, "p"));
  const auto v = JudgeJob("hexapod_calibration", JobStatus::kDone, r, "");
  EXPECT_EQ(v.verdict, "warning");
  ASSERT_EQ(v.reasons.size(), 4u);
  EXPECT_NE(v.reasons[0].find("not converged"), std::string::npos) << v.reasons[0];
  EXPECT_NE(v.reasons[0].find("50 iterations"), std::string::npos) << v.reasons[0];
  EXPECT_NE(v.reasons[1].find("condition number 178483"), std::string::npos) << v.reasons[1];
  EXPECT_NE(v.reasons[2].find("±2678"), std::string::npos) << v.reasons[2];
  EXPECT_NE(v.reasons[3].find("15 parameters"), std::string::npos) << v.reasons[3];
}

TEST(JobVerdict, EachConditionAloneIsEnough) {
  auto r = GoodCalibration();
  r["condition_number"] = 2 * kIllConditionedAbove;
  EXPECT_EQ(JudgeJob("hexapod_calibration", JobStatus::kDone, r, "").verdict, "warning");
  r = GoodCalibration();
  r["converged"] = false;
  EXPECT_EQ(JudgeJob("hexapod_calibration", JobStatus::kDone, r, "").verdict, "warning");
  r = GoodCalibration();
  r["parameter_uncertainty_um"]["strut_offset_um"][3] = 1.5 * kUndeterminedAboveUm;
  EXPECT_EQ(JudgeJob("hexapod_calibration", JobStatus::kDone, r, "").verdict, "warning");
  r = GoodCalibration();
  r["fixed_parameters"] = {"base_joint_offset_um[0][0]"};
  EXPECT_EQ(JudgeJob("hexapod_calibration", JobStatus::kDone, r, "").verdict, "warning");
  // Numbers that are not numbers fail it (NaN is stored as null).
  r = GoodCalibration();
  r["condition_number"] = nullptr;
  EXPECT_EQ(JudgeJob("hexapod_calibration", JobStatus::kDone, r, "").verdict, "failed");
  r = GoodCalibration();
  r["parameter_uncertainty_um"]["strut_offset_um"][0] = nullptr;
  EXPECT_EQ(JudgeJob("hexapod_calibration", JobStatus::kDone, r, "").verdict, "failed");
}

TEST(JobVerdict, DiscoveriesFailedAndRunningJobs) {
  EXPECT_EQ(JudgeJob("discovery", JobStatus::kDone,
                     {{"verdict", "complete"}, {"condition_number", 3e7}}, "")
                .verdict,
            "ok");
  const auto misfit = JudgeJob("discovery", JobStatus::kDone,
                               {{"verdict", "model misfit"}, {"stop_reason", "no candidate"}}, "");
  EXPECT_EQ(misfit.verdict, "warning");
  ASSERT_EQ(misfit.reasons.size(), 1u);
  EXPECT_NE(misfit.reasons[0].find("no candidate"), std::string::npos);
  const auto failed =
      JudgeJob("hexapod_calibration", JobStatus::kFailed, nullptr, "did not converge");
  EXPECT_EQ(failed.verdict, "failed");
  EXPECT_EQ(failed.reasons, std::vector<std::string>{"did not converge"});
  EXPECT_EQ(JudgeJob("discovery", JobStatus::kRunning, nullptr, "").verdict, "");
  EXPECT_EQ(JudgeJob("hexapod_calibration", JobStatus::kDone, nullptr, "").verdict, "failed");
  // The job JSON carries the verdict and its reasons.
  JobRecord job;
  job.id = JobId(3);
  job.kind = "hexapod_calibration";
  job.status = JobStatus::kDone;
  job.request_json = "{}";
  job.result_json = GoodCalibration().dump();
  JobKinds kinds;
  kinds.Add(kCalibrationJob, {nullptr, JudgeCalibrationResult});
  const auto j = kinds.Json(job);
  EXPECT_EQ(j["verdict"], "ok");
  EXPECT_TRUE(j["verdict_reasons"].empty());
  job.status = JobStatus::kRunning;
  job.result_json.clear();
  EXPECT_TRUE(kinds.Json(job)["verdict"].is_null());
}

}  // namespace
}  // namespace km::server
