#include "api/worker_pool.h"

#include <chrono>

#include <sched.h>

namespace km::api {
namespace {
// How long a thread that finished a task watches the queue before it sleeps: about two
// requests' interval at 20 000 requests a second.
constexpr auto kWatch = std::chrono::microseconds(100);
}  // namespace

WorkerPool::WorkerPool(int threads, std::size_t queue_limit) : limit_(queue_limit) {
  for (int i = 0; i < threads; ++i) threads_.emplace_back([this] { Work(); });
}

WorkerPool::~WorkerPool() {
  Stop();
}

bool WorkerPool::TryPost(std::function<void()> task) {
  {
    std::lock_guard lock(mu_);
    if (stop_ || tasks_.size() >= limit_) return false;
    tasks_.push_back(std::move(task));
    queued_.store(tasks_.size());
  }
  // A watching thread takes it; it re-checks the queue under the lock before it sleeps, so
  // the task is never left behind (both sides use the lock and sequentially consistent
  // atomics).
  if (watching_.load() == 0) cv_.notify_one();
  return true;
}

void WorkerPool::Post(std::function<void()> task) {
  {
    std::lock_guard lock(mu_);
    if (stop_) return;
    tasks_.push_back(std::move(task));
    queued_.store(tasks_.size());
  }
  if (watching_.load() == 0) cv_.notify_one();
}

void WorkerPool::Stop() {
  std::deque<std::function<void()>> dropped;
  {
    std::lock_guard lock(mu_);
    stop_ = true;
    dropped.swap(tasks_);
    queued_.store(0);
  }
  cv_.notify_all();
  for (auto& t : threads_) {
    if (t.joinable()) t.join();
  }
  // `dropped` goes out of scope here, outside the lock: the tasks' captures may own sessions.
}

std::function<void()> WorkerPool::TakeLocked() {
  std::function<void()> task;
  if (stop_ || tasks_.empty()) return task;
  task = std::move(tasks_.front());
  tasks_.pop_front();
  queued_.store(tasks_.size());
  return task;
}

std::function<void()> WorkerPool::Watch() {
  int none = 0;
  if (!watching_.compare_exchange_strong(none, 1)) return {};  // another thread watches
  const auto until = std::chrono::steady_clock::now() + kWatch;
  std::function<void()> task;
  while (!task) {
    if (queued_.load() > 0) {
      std::lock_guard lock(mu_);
      task = TakeLocked();
      if (stop_) break;
    } else if (std::chrono::steady_clock::now() >= until) {
      break;
    } else {
      sched_yield();
    }
  }
  watching_.store(0);
  return task;
}

void WorkerPool::Work() {
  std::function<void()> task;
  while (true) {
    if (!task) {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stop_ || !tasks_.empty(); });
      if (stop_) return;
      task = TakeLocked();
    }
    task();
    task = nullptr;  // its captures (a session) released before the watch, as before
    task = Watch();
  }
}

}  // namespace km::api
