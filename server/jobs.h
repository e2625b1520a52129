// Background jobs: one worker thread runs submitted work in order; status, progress and the
// result are kept in storage, so they survive the request that started them and are served
// later. Jobs left unfinished by a stopped server are marked failed at the next start.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/storage.h"

namespace km::server {

class JobQueue {
 public:
  using Progress = std::function<void(double, const std::string&)>;
  using Work = std::function<nlohmann::json(const Progress&)>;

  explicit JobQueue(Storage& storage, std::size_t max_queued = 16);
  ~JobQueue();  // finishes the running job, fails the queued ones, joins the worker
  JobQueue(const JobQueue&) = delete;
  JobQueue& operator=(const JobQueue&) = delete;

  // Stores the job as queued and schedules it. Throws km::Error when the queue is full.
  std::int64_t Submit(const std::string& kind, const nlohmann::json& request, Work work);

 private:
  void Run();
  Storage& storage_;
  std::size_t max_queued_;
  std::deque<std::pair<std::int64_t, Work>> queue_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread worker_;
};

// The job as the API serves it: id, kind, status, progress, stage, times, request, result,
// error, and the verdict on its outcome (JudgeJob) as "verdict" and "verdict_reasons".
nlohmann::json JobJson(const JobRecord& job);

// The verdict on a background job's outcome (docs/formats.md §5): can its figures be trusted?
// A calibration or discovery that finished may still be ill-conditioned, not converged or
// under-determined: its numbers are then not a result, and the verdict says why.
// Above this condition number (of the Jacobian over the free parameters) the tests do not tell
// the parameters apart: small changes of the readings move them a lot.
inline constexpr double kIllConditionedAbove = 1e4;
// Above this standard uncertainty of an identified parameter (µm) the tests do not determine it:
// the errors a calibration corrects are tens of µm.
inline constexpr double kUndeterminedAboveUm = 25.0;

struct JobVerdict {
  std::string verdict;  // "ok", "warning", "failed"; empty while the job is queued or running
  std::vector<std::string> reasons;  // empty when "ok"
};

// kind: "hexapod_calibration" or "discovery" (other kinds: "ok" when done); status: queued,
// running, done, failed; result: the stored result (null when none); error: when failed.
JobVerdict JudgeJob(const std::string& kind, const std::string& status,
                    const nlohmann::json& result, const std::string& error);

}  // namespace km::server
