// The kinds of background job, each registered with its runner and its judge side by side (the
// studies register theirs in server/jobs/study_service.cpp), so the queue (server/jobs/jobs.h)
// knows nothing of any kind: it runs a stored plan with the kind's runner and stores what the
// runner produced. A job's answer (JobKinds::Json) carries the verdict of its kind's judge.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/core/progress.h"
#include "server/storage/storage.h"

namespace km::server {

// What a job's runner produced: the result the API answers, and the machine definition it
// produced, exactly as the machine writer wrote it (empty: none). The queue stores both as they
// are; saving the job's machine stores that text unchanged (StudyService::SaveJobMachine).
struct JobOutput {
  nlohmann::json result;
  std::string machine_document;
};

// The verdict on a background job's outcome (docs/formats.md §5): can its figures be trusted?
// A study that finished may still be ill-conditioned, not converged or under-determined: its
// numbers are then not a result, and the verdict says why.
struct JobVerdict {
  std::string verdict;  // "ok", "warning", "failed"; empty while the job is queued or running
  std::vector<std::string> reasons;  // empty when "ok"
};

// What a kind's judge finds in a finished job's result: warnings, or failures.
struct JobFindings {
  bool failed = false;
  std::vector<std::string> reasons;
  void Warn(const std::string& why) { reasons.push_back(why); }
  void Fail(const std::string& why) {
    failed = true;
    reasons.push_back(why);
  }
};

// A figure in a verdict's sentence: whole numbers from 100 up, else three significant digits.
std::string VerdictNumber(double v);
// The condition number of a result ("condition_number"): not finite fails (the tests do not
// determine every parameter); above `bound` warns (bound 0: no bound applies).
void JudgeConditionNumber(const nlohmann::json& result, double bound, JobFindings& out);

struct JobKind {
  // Runs a job from its stored plan, reporting progress (which throws when the job is to stop).
  std::function<JobOutput(const nlohmann::json& plan, const ProgressFn&)> run;
  // Judges the result of a job that is done (an object); empty: every result is "ok".
  std::function<void(const nlohmann::json& result, JobFindings&)> judge;
};

// The verdict on a job of a kind judged by `judge`: "failed" with its error when it failed, none
// while queued, running or cancelled, "failed" when done without a result, else the judge's.
JobVerdict JudgeJobOutcome(const std::function<void(const nlohmann::json&, JobFindings&)>& judge,
                           JobStatus status, const nlohmann::json& result,
                           const std::string& error);

class JobKinds {
 public:
  void Add(const std::string& name, JobKind kind) { kinds_[name] = std::move(kind); }
  const JobKind* Find(const std::string& name) const;
  // The verdict on a stored job (a kind not registered here: "ok" when done); `result`: its
  // result_json parsed already (null when empty).
  JobVerdict Verdict(const JobRecord& job) const;
  JobVerdict Verdict(const JobRecord& job, const nlohmann::json& result) const;
  // The job as the API serves it: id, kind, status, progress, stage, times, request, result,
  // error, instance, attempts, owner_token_id (null when not known), and the verdict of its
  // kind's judge as "verdict" and "verdict_reasons".
  nlohmann::json Json(const JobRecord& job) const;

 private:
  std::map<std::string, JobKind> kinds_;
};

}  // namespace km::server
