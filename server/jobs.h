// Background jobs: one worker thread runs submitted work in order; status, progress and the
// result are kept in storage, so they survive the request that started them and are served
// later. Jobs left unfinished by a stopped server are marked failed at the next start.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>

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

nlohmann::json JobJson(const JobRecord& job);

}  // namespace km::server
