// Background jobs (calibration and discovery studies), queued in the database: every instance
// on the database takes jobs from the same queue under a lease it renews while the job runs
// (its progress reports and a heartbeat), so adding an instance adds capacity, and a job whose
// instance died is taken over by another when the lease runs out. A stopping instance gives its
// running jobs back to the queue; queued jobs wait for the next instance. A job is stored with
// its plan (the checked request, the machine resolved), from which any instance runs it with
// the runner of its kind (server/jobs/job_kinds.h); the queue itself knows no kind.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/core/progress.h"
#include "server/jobs/job_kinds.h"
#include "server/storage/storage.h"

namespace km::server {

struct JobQueueOptions {
  std::size_t max_queued = 16;  // queued jobs (of every instance) beyond which Submit refuses
  int workers = 1;              // jobs this instance runs at once (0: it queues jobs but runs none)
  std::int64_t lease_ms = 30'000;  // a job not renewed for this long is another's to take
  std::int64_t poll_ms = 1'000;    // how often an idle worker looks for other instances' jobs
  int max_attempts = 3;            // starts of a job before its lapsed lease fails it
  std::string instance;            // the lease owner's name; empty: host:pid:random
};

class JobQueue {
 public:
  // kinds: the runner of every kind the queue takes (complete before Start, and outliving the
  // queue); a job of another kind fails naming it.
  JobQueue(JobStore& storage, const JobKinds& kinds, JobQueueOptions options = {});
  ~JobQueue();  // Stop()
  JobQueue(const JobQueue&) = delete;
  JobQueue& operator=(const JobQueue&) = delete;

  void Start();
  // Stops taking jobs. A running job stops at its next progress report and goes back to the
  // queue, to be run again by this or another instance; the workers are joined.
  void Stop();

  // Stores the job as queued (request: what the API shows; plan: what a worker runs) and wakes
  // a worker. Throws Unavailable when max_queued jobs are waiting.
  JobId Submit(const std::string& kind, const nlohmann::json& request, const nlohmann::json& plan,
               std::optional<TokenId> owner_token_id = std::nullopt);
  // Cancels a queued or running job (reason: its error); false when it is neither. A job
  // running here stops at its next progress report, its worker free for the next job; one
  // running on another instance stops there when its next report is refused by the storage.
  bool Cancel(JobId id, const std::string& reason);
  const std::string& instance() const { return options_.instance; }

 private:
  struct Running {
    double progress = 0.0;
    std::string stage;
    bool lost = false;  // the job is no longer ours: cancelled, or another instance runs it
  };
  void Work();
  void Heartbeat();
  std::optional<JobRecord> TryClaim();
  void RunJob(JobRecord job);
  JobOutput RunPlan(const JobRecord& job);
  void Report(JobId id, double progress, const std::string& stage);
  void Finish(JobRecord job);
  std::int64_t LeaseEnd() const;

  JobStore& storage_;
  JobQueueOptions options_;
  const JobKinds& kinds_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool started_ = false, stop_ = false;
  std::size_t pending_ = 0;  // submissions not yet looked for by a worker
  std::map<JobId, Running> running_;
  std::vector<std::thread> workers_;
  std::thread heartbeat_;
};

}  // namespace km::server
