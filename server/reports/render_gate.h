// The gate of PDF renders (server/reports/report_service.h): reports are made on the gate's own
// threads, at most `max_running` at a time, and at most `max_waiting` more wait for one; beyond
// that a request is refused at once with km::Unavailable (HTTP 503 with Retry-After), so a burst
// of large reports holds neither every request thread nor the memory of every report at once.
// The caller waits for its report; a report that waited `max_wait` without starting is refused.
// Stop: new and waiting reports are refused at once, the running ones are told to give up
// (their render asks between blocks, rows and pages) from `cancel_at` on, and their callers
// are answered then even if the work has not yet noticed. After each report the memory it
// freed is handed back to the system (glibc malloc_trim).
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(__linux__)
#include <sys/resource.h>
#include <unistd.h>
#endif

#include "analysis/core/errors.h"

namespace km::server {

struct RenderGateOptions {
  // Reports made at a time: half the cores, at least 1, at most 3 (a server has 8 request
  // threads by default; running and waiting reports together keep some of them free).
  int max_running = std::clamp(static_cast<int>(std::thread::hardware_concurrency()) / 2, 1, 3);
  int max_waiting = -1;  // reports waiting for a turn; -1: max_running
  std::chrono::milliseconds max_wait{10'000};
};

class RenderGate {
 public:
  using Clock = std::chrono::steady_clock;
  // Makes a report; `cancelled` says when to give up (km::render::RenderCancelled).
  using Job = std::function<std::string(const std::function<bool()>& cancelled)>;

  explicit RenderGate(RenderGateOptions options = {});
  ~RenderGate();  // cancels the running reports at once, refuses the waiting ones, joins
  RenderGate(const RenderGate&) = delete;
  RenderGate& operator=(const RenderGate&) = delete;

  // The job's bytes, made on a gate thread; throws what the job throws, km::Unavailable when
  // the gate is full, stopped, or the job waited too long.
  std::string Run(Job job);
  // Refuses new and waiting reports now; running ones are cancelled from `cancel_at` on.
  void Stop(Clock::time_point cancel_at);
  int running() const;
  std::size_t waiting() const;

 private:
  struct Task {
    Job job;
    std::promise<std::string> done;
    Clock::time_point queued;
  };
  void Work();
  bool Cancelled() const;
  void Refuse(Task& t, const std::string& why);

  RenderGateOptions options_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::shared_ptr<Task>> queue_;
  int running_ = 0;
  bool stopping_ = false;
  std::atomic<bool> stop_requested_{false};
  std::atomic<Clock::rep> cancel_at_{0};  // time since the clock's epoch
  std::vector<std::thread> threads_;
};

inline RenderGate::RenderGate(RenderGateOptions options) : options_(options) {
  options_.max_running = std::max(1, options_.max_running);
  if (options_.max_waiting < 0) options_.max_waiting = options_.max_running;
  for (int i = 0; i < options_.max_running; ++i) threads_.emplace_back([this] { Work(); });
}

inline RenderGate::~RenderGate() {
  Stop(Clock::now());
  cv_.notify_all();
  for (auto& t : threads_) t.join();
}

inline std::string RenderGate::Run(Job job) {
  auto task = std::make_shared<Task>();
  task->job = std::move(job);
  task->queued = Clock::now();
  auto done = task->done.get_future();
  {
    std::lock_guard lock(mu_);
    if (stopping_) throw Unavailable("the server is stopping; no report is made now");
    const auto busy = static_cast<std::size_t>(running_) + queue_.size();
    if (busy >= static_cast<std::size_t>(options_.max_running + options_.max_waiting)) {
      throw Unavailable(std::to_string(running_) + " reports are being made and " +
                        std::to_string(queue_.size()) +
                        " wait for their turn (the most at once); retry shortly");
    }
    queue_.push_back(std::move(task));
  }
  cv_.notify_one();
  // Once the stop's deadline has passed, the caller is answered even if the job has not yet
  // noticed it (it runs on, owned by the gate's thread).
  while (done.wait_for(std::chrono::milliseconds(50)) != std::future_status::ready) {
    if (Cancelled()) {
      throw Unavailable("the report was not finished: the server is stopping; retry shortly");
    }
  }
  return done.get();
}

inline void RenderGate::Stop(Clock::time_point cancel_at) {
  std::deque<std::shared_ptr<Task>> refused;
  {
    std::lock_guard lock(mu_);
    if (!stopping_ || cancel_at.time_since_epoch().count() < cancel_at_.load()) {
      cancel_at_ = cancel_at.time_since_epoch().count();
    }
    stopping_ = true;
    stop_requested_ = true;
    refused.swap(queue_);
  }
  for (auto& t : refused) Refuse(*t, "the server is stopping; no report is made now");
  cv_.notify_all();
}

inline int RenderGate::running() const {
  std::lock_guard lock(mu_);
  return running_;
}

inline std::size_t RenderGate::waiting() const {
  std::lock_guard lock(mu_);
  return queue_.size();
}

inline bool RenderGate::Cancelled() const {
  return stop_requested_.load() && Clock::now().time_since_epoch().count() >= cancel_at_.load();
}

inline void RenderGate::Refuse(Task& t, const std::string& why) {
  t.done.set_exception(std::make_exception_ptr(Unavailable(why)));
}

inline void RenderGate::Work() {
#if defined(__linux__)
  // Below the request threads: on a small machine a report yields the cores to requests.
  setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 10);
#endif
  const std::function<bool()> cancelled = [this] { return Cancelled(); };
  while (true) {
    std::shared_ptr<Task> task;
    {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping, nothing left
      task = std::move(queue_.front());
      queue_.pop_front();
      ++running_;
    }
    if (Clock::now() - task->queued > options_.max_wait) {
      Refuse(*task, "the report waited too long for its turn; retry shortly");
    } else {
      try {
        task->done.set_value(task->job(cancelled));
      } catch (...) {
        task->done.set_exception(std::current_exception());
      }
    }
    task.reset();  // the job's captures and bytes, before the memory is handed back
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
    std::lock_guard lock(mu_);
    --running_;
  }
}

}  // namespace km::server
