#include "server/jobs.h"

#include <iostream>
#include <optional>

#include "analysis/core/errors.h"

namespace km::server {
namespace {

// One storage update of the worker. A storage error (a full disk, a locked or damaged
// database) must not end the process: it is reported on stderr with the job id and returned.
std::optional<std::string> TryUpdate(Storage& storage, const JobRecord& job, const char* what) {
  std::string error;
  try {
    storage.UpdateJob(job);
    return std::nullopt;
  } catch (const std::exception& e) {
    error = e.what();
  } catch (...) {
    error = "unknown storage error";
  }
  try {
    std::cerr << "kinemetricd: job " << job.id << ": could not store " << what << " (" << job.status
              << "): " << error << std::endl;
  } catch (...) {  // NOLINT(bugprone-empty-catch): nothing is left to report to
  }
  return error;
}

}  // namespace

JobQueue::JobQueue(Storage& storage, std::size_t max_queued)
    : storage_(storage), max_queued_(max_queued) {
  storage_.FailInterruptedJobs("the server stopped before the job finished; submit it again");
  worker_ = std::thread([this] { Run(); });
}

JobQueue::~JobQueue() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  worker_.join();
  for (const auto& [id, work] : queue_) {
    JobRecord j;
    j.id = id;
    j.status = "failed";
    j.error = "the server stopped before the job started; submit it again";
    try {
      TryUpdate(storage_, j, "that it was not started");
    } catch (...) {  // NOLINT(bugprone-empty-catch): a destructor must not throw
    }
  }
}

std::int64_t JobQueue::Submit(const std::string& kind, const nlohmann::json& request, Work work) {
  std::lock_guard lock(mu_);
  if (queue_.size() >= max_queued_) {
    throw Unavailable("the job queue is full (" + std::to_string(max_queued_) +
                      " jobs waiting); try again later");
  }
  const std::int64_t id = storage_.CreateJob(kind, request.dump());
  queue_.emplace_back(id, std::move(work));
  cv_.notify_one();
  return id;
}

void JobQueue::Run() {
  while (true) {
    std::pair<std::int64_t, Work> item;
    {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      item = std::move(queue_.front());
      queue_.pop_front();
    }
    // Every storage call below is guarded: the job runs even when its status cannot be
    // written, and the worker goes on to the next job whatever happens to this one.
    try {
      JobRecord job;
      job.id = item.first;
      job.status = "running";
      job.stage = "started";
      TryUpdate(storage_, job, "its start");
      auto progress = [&](double f, const std::string& stage) {
        job.progress = f;
        job.stage = stage;
        TryUpdate(storage_, job, "its progress");
      };
      try {
        const nlohmann::json result = item.second(progress);
        job.status = "done";
        job.progress = 1.0;
        job.stage = "done";
        job.result_json = result.dump();
      } catch (const std::exception& e) {
        job.status = "failed";
        job.error = e.what();
      } catch (...) {
        job.status = "failed";
        job.error = "the job failed with an unknown error";
      }
      const auto error = TryUpdate(storage_, job, "its outcome");
      if (error && job.status == "done") {
        // The result could not be written (too large, disk full): record at least the failure.
        JobRecord failed = job;
        failed.status = "failed";
        failed.stage = "storing the result";
        failed.result_json.clear();
        failed.error = "the result could not be stored: " + *error;
        TryUpdate(storage_, failed, "its failure");
      }
    } catch (...) {
      // Out of memory or the like while handling one job: the worker stays for the next.
      try {
        std::cerr << "kinemetricd: job " << item.first << ": aborted" << std::endl;
      } catch (...) {  // NOLINT(bugprone-empty-catch): nothing is left to report to
      }
    }
  }
}

nlohmann::json JobJson(const JobRecord& job) {
  nlohmann::json j;
  j["id"] = job.id;
  j["kind"] = job.kind;
  j["status"] = job.status;
  j["progress"] = job.progress;
  j["stage"] = job.stage;
  j["created_at"] = job.created_at;
  j["updated_at"] = job.updated_at;
  j["request"] =
      job.request_json.empty() ? nlohmann::json(nullptr) : nlohmann::json::parse(job.request_json);
  if (!job.result_json.empty()) j["result"] = nlohmann::json::parse(job.result_json);
  if (!job.error.empty()) j["error"] = job.error;
  return j;
}

}  // namespace km::server
