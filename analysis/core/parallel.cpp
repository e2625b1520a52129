#include "analysis/core/parallel.h"

#include <system_error>

namespace km::internal {

WorkerPool& WorkerPool::Instance() {
  static WorkerPool pool;
  return pool;
}

WorkerPool::WorkerPool() {
  const unsigned cores = std::thread::hardware_concurrency();
  const unsigned want = cores > 1 ? cores - 1 : 1;
  for (unsigned k = 0; k < want; ++k) {
    try {
      threads_.emplace_back([this] { Loop(); });
    } catch (const std::system_error&) {
      break;  // no more threads: the callers do the work
    }
  }
}

WorkerPool::~WorkerPool() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& t : threads_) t.join();
}

bool WorkerPool::Post(std::function<void()> job) {
  if (threads_.empty()) return false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    queue_.push_back(std::move(job));
    queued_.store(queue_.size());
  }
  cv_.notify_one();
  return true;
}

bool WorkerPool::TryRunOne() {
  std::function<void()> job;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (queue_.empty()) return false;
    job = std::move(queue_.front());
    queue_.erase(queue_.begin());
    queued_.store(queue_.size());
  }
  job();
  return true;
}

void WorkerPool::Loop() {
  for (;;) {
    // The next part of an analysis usually follows within microseconds: watch, then sleep.
    SpinUntil([this] { return HasQueued(); });
    std::function<void()> job;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping, nothing left
      job = std::move(queue_.front());
      queue_.erase(queue_.begin());
      queued_.store(queue_.size());
    }
    job();
  }
}

}  // namespace km::internal
