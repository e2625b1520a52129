#include "server/jobs.h"

#include "analysis/core/errors.h"

namespace km::server {

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
    storage_.UpdateJob(j);
  }
}

std::int64_t JobQueue::Submit(const std::string& kind, const nlohmann::json& request, Work work) {
  std::lock_guard lock(mu_);
  if (queue_.size() >= max_queued_) {
    throw Error("the job queue is full (" + std::to_string(max_queued_) +
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
    JobRecord job;
    job.id = item.first;
    job.status = "running";
    job.stage = "started";
    storage_.UpdateJob(job);
    auto progress = [&](double f, const std::string& stage) {
      job.progress = f;
      job.stage = stage;
      storage_.UpdateJob(job);
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
    }
    storage_.UpdateJob(job);
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
