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

}  // namespace km::server
