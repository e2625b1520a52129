#include "server/jobs/jobs.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>
#include <random>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"

namespace km::server {
namespace {

// A running job stops at its next progress report: the instance stops, or lost its lease.
struct JobInterrupted {};

std::int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// host:pid:random — unique among the instances sharing a database.
std::string InstanceName() {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  std::random_device rd;
  char tail[16];
  std::snprintf(tail, sizeof tail, "%08x", static_cast<unsigned>(rd()));
  return std::string(host[0] ? host : "host") + ":" + std::to_string(getpid()) + ":" + tail;
}

// The worker's storage calls must not end the process (a full disk, a locked or unreachable
// database): a failure is reported on stderr with the job id.
// The job is none for the queue's own storage calls.
void LogJob(std::optional<JobId> id, const std::string& message) {
  try {
    std::cerr << "kinemetricd: " << (id ? "job " + to_string(*id) : std::string("job queue"))
              << ": " << message << std::endl;
  } catch (...) {  // NOLINT(bugprone-empty-catch): nothing is left to report to
  }
}

void LogStoreFailure(std::optional<JobId> id, const char* what, const std::string& error) {
  LogJob(id, std::string("could not store ") + what + ": " + error);
}

template <class F>
std::optional<std::string> Guarded(F&& call) {
  try {
    call();
    return std::nullopt;
  } catch (const std::exception& e) {
    return std::string(e.what());
  } catch (...) {
    return std::string("unknown storage error");
  }
}

}  // namespace

JobQueue::JobQueue(JobStore& storage, const JobKinds& kinds, JobQueueOptions options)
    : storage_(storage), options_(std::move(options)), kinds_(kinds) {
  if (options_.instance.empty()) options_.instance = InstanceName();
  options_.workers = std::max(options_.workers, 0);
  options_.lease_ms = std::max<std::int64_t>(options_.lease_ms, 100);
  options_.poll_ms = std::max<std::int64_t>(options_.poll_ms, 10);
  options_.max_attempts = std::max(options_.max_attempts, 1);
}

JobQueue::~JobQueue() {
  Stop();
}

void JobQueue::Start() {
  std::lock_guard lock(mu_);
  if (started_) return;
  started_ = true;
  if (options_.workers == 0) return;  // an instance that runs no jobs
  for (int i = 0; i < options_.workers; ++i) workers_.emplace_back([this] { Work(); });
  heartbeat_ = std::thread([this] { Heartbeat(); });
}

void JobQueue::Stop() {
  {
    std::lock_guard lock(mu_);
    if (!started_ || stop_) return;
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& w : workers_) w.join();
  if (heartbeat_.joinable()) heartbeat_.join();
  // The jobs interrupted above wait in the queue for the next instance.
  if (const auto error = Guarded([&] { storage_.ReleaseJobs(options_.instance); })) {
    LogStoreFailure(std::nullopt, "that this instance's jobs are free to run again", *error);
  }
}

JobId JobQueue::Submit(const std::string& kind, const nlohmann::json& request,
                       const nlohmann::json& plan, std::optional<TokenId> owner_token_id) {
  if (storage_.CountJobsWithStatus(JobStatus::kQueued) >=
      static_cast<std::int64_t>(options_.max_queued)) {
    throw Unavailable("the job queue is full (" + std::to_string(options_.max_queued) +
                      " jobs waiting); try again later");
  }
  const JobId id = storage_.QueueJob(NewJob{kind, request.dump(), plan.dump(), owner_token_id});
  {
    std::lock_guard lock(mu_);
    ++pending_;
  }
  cv_.notify_all();  // the heartbeat waits on it too
  return id;
}

bool JobQueue::Cancel(JobId id, const std::string& reason) {
  if (!storage_.CancelJob(id, reason)) return false;
  std::lock_guard lock(mu_);
  if (const auto it = running_.find(id); it != running_.end()) it->second.lost = true;
  return true;
}

void JobQueue::Work() {
  std::unique_lock lock(mu_);
  while (!stop_) {
    if (pending_ > 0) --pending_;
    lock.unlock();
    auto job = TryClaim();
    if (job) RunJob(std::move(*job));
    lock.lock();
    if (!job) {
      cv_.wait_for(lock, std::chrono::milliseconds(options_.poll_ms),
                   [this] { return stop_ || pending_ > 0; });
    }
  }
}

std::optional<JobRecord> JobQueue::TryClaim() {
  // Said of a job that was started max_attempts times and never finished: each time its
  // instance stopped (killed, or crashed — possibly by this job) while running it.
  const std::string abandoned = "the job was started " + std::to_string(options_.max_attempts) +
                                " times and each time the server running it stopped before it "
                                "finished (killed, or crashed while running it: see that "
                                "server's log); it is not started again";
  std::optional<JobRecord> job;
  if (const auto error = Guarded([&] {
        job = storage_.ClaimJob(options_.instance, NowMs(), options_.lease_ms,
                                options_.max_attempts, abandoned);
      })) {
    LogStoreFailure(std::nullopt, "the claim of a queued job", *error);
    return std::nullopt;
  }
  return job;
}

std::int64_t JobQueue::LeaseEnd() const {
  return NowMs() + options_.lease_ms;
}

void JobQueue::Heartbeat() {
  std::unique_lock lock(mu_);
  const auto period = std::chrono::milliseconds(std::max<std::int64_t>(options_.lease_ms / 3, 10));
  while (!cv_.wait_for(lock, period, [this] { return stop_; })) {
    const auto running = running_;
    lock.unlock();
    for (const auto& entry : running) {
      const JobId id = entry.first;
      const Running& r = entry.second;
      if (r.lost) continue;
      bool held = true;
      if (const auto error = Guarded([&] {
            held = storage_.RenewJob(id, options_.instance, r.progress, r.stage, LeaseEnd());
          })) {
        LogStoreFailure(id, "its lease", *error);
      }
      if (!held) {
        std::lock_guard relock(mu_);
        if (auto it = running_.find(id); it != running_.end()) it->second.lost = true;
      }
    }
    lock.lock();
  }
}

void JobQueue::Report(JobId id, double progress, const std::string& stage) {
  {
    std::lock_guard lock(mu_);
    auto& r = running_[id];
    if (stop_ || r.lost) throw JobInterrupted{};
    r.progress = progress;
    r.stage = stage;
  }
  bool held = true;
  if (const auto error = Guarded(
          [&] { held = storage_.RenewJob(id, options_.instance, progress, stage, LeaseEnd()); })) {
    LogStoreFailure(id, "its progress", *error);
  }
  if (!held) {
    std::lock_guard lock(mu_);
    running_[id].lost = true;
    throw JobInterrupted{};
  }
}

JobOutput JobQueue::RunPlan(const JobRecord& job) {
  const JobKind* kind = kinds_.Find(job.kind);
  if (!kind || !kind->run) {
    throw Error("this server does not run jobs of kind '" + job.kind + "'");
  }
  if (job.plan_json.empty()) {
    throw Error(
        "the job was queued by an earlier version of the server, without its plan; "
        "submit it again");
  }
  const auto plan = ingest::ParseJsonText(job.plan_json, "stored document");
  return kind->run(plan, [&](double f, const std::string& stage) { Report(job.id, f, stage); });
}

void JobQueue::RunJob(JobRecord job) {
  {
    std::lock_guard lock(mu_);
    running_[job.id] = Running{0.0, job.stage, false};
  }
  bool interrupted = false;
  try {
    JobOutput out = RunPlan(job);
    job.result_json = out.result.dump();
    job.machine_document = std::move(out.machine_document);
    job.status = JobStatus::kDone;
    job.progress = 1.0;
    job.stage = "done";
  } catch (const JobInterrupted&) {
    interrupted = true;
  } catch (const Error& e) {  // the product's own errors are written for the user
    job.status = JobStatus::kFailed;
    job.error = e.what();
  } catch (const std::exception& e) {  // anything else is ours to look at, not the user's
    job.status = JobStatus::kFailed;
    job.error = "the job failed with an internal error (logged by the server as job " +
                to_string(job.id) + ")";
    LogJob(job.id, std::string("failed: ") + e.what());
  } catch (...) {
    job.status = JobStatus::kFailed;
    job.error = "the job failed with an unknown error";
  }
  bool lost = false;
  {
    std::lock_guard lock(mu_);
    lost = running_[job.id].lost;
    running_.erase(job.id);
  }
  // Interrupted: given back to the queue when the instance stops, or run by another instance.
  if (!interrupted && !lost) Finish(std::move(job));
}

void JobQueue::Finish(JobRecord job) {
  bool held = true;
  auto error = Guarded([&] { held = storage_.FinishJob(job, options_.instance); });
  if (error && job.status == JobStatus::kDone) {
    LogStoreFailure(job.id, "its result", *error);
    // The result could not be written (too large, disk full): record at least the failure.
    job.status = JobStatus::kFailed;
    job.stage = "storing the result";
    job.result_json.clear();
    job.machine_document.clear();
    job.error = "the result could not be stored: " + *error;
    error = Guarded([&] { held = storage_.FinishJob(job, options_.instance); });
  }
  if (error) LogStoreFailure(job.id, "its outcome", *error);
  if (!held) {
    LogJob(job.id,
           "its outcome is dropped: the job was cancelled, or its lease ran out and another "
           "instance runs it");
  }
}

}  // namespace km::server
