// ParallelFor: independent calls fn(0) … fn(n − 1) spread over the machine's cores (the calling
// thread included). Used where an analysis has independent parts (the tests of a DBB set, the
// two axes of a search), so that a user waiting for one result gets it sooner on a multi-core
// machine; the result is the same as running the calls in order.
//
// The helpers are threads of one process-wide pool started on first use (no thread is created
// per call). The caller claims indices itself until none is left and then waits only for the
// indices a helper is running, so nested calls (a parallel part that itself runs ParallelFor)
// cannot deadlock, and a call never waits for a helper that has not started.
//
// An analysis is a chain of short parallel parts (a DBB pair's diagnosis has dozens of 0.05–0.5
// ms ones). Waking a sleeping thread takes tens of microseconds, up to a scheduler tick on a
// virtual machine, so a helper that runs out of work and a caller waiting for its helpers first
// watch for the next part for a short while (kSpinMicroseconds) before they sleep.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace km {

namespace internal {

inline constexpr int kSpinMicroseconds = 100;

// Calls done() until it is true or kSpinMicroseconds have passed; its last answer.
template <typename Done>
bool SpinUntil(Done&& done) {
  const auto until =
      std::chrono::steady_clock::now() + std::chrono::microseconds(kSpinMicroseconds);
  for (int k = 0;; ++k) {
    if (done()) return true;
    if ((k & 63) == 63 && std::chrono::steady_clock::now() > until) return done();
    std::this_thread::yield();
  }
}

// Runs posted jobs on hardware_concurrency − 1 threads (at least one).
class WorkerPool {
 public:
  static WorkerPool& Instance();
  // Queues `job`; false when the pool has no thread (the caller then does the work itself).
  bool Post(std::function<void()> job);
  // Runs one queued job on the calling thread; false when the queue is empty. A ParallelFor
  // waiting for its helpers runs queued jobs meanwhile (e.g. those of a nested ParallelFor
  // started by one of its own calls), so no thread sits idle while work is queued.
  bool TryRunOne();
  // True when a job is queued (a hint, read without the lock).
  bool HasQueued() const { return queued_.load(std::memory_order_relaxed) > 0; }
  std::size_t size() const { return threads_.size(); }
  ~WorkerPool();

 private:
  WorkerPool();
  void Loop();
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::function<void()>> queue_;
  std::atomic<std::size_t> queued_{0};  // queue_.size(), readable without the lock
  std::vector<std::thread> threads_;
  bool stop_ = false;
};

// The shared state of one ParallelFor call.
struct ParallelState {
  explicit ParallelState(std::size_t count) : n(count), errors(count) {}
  std::size_t n;
  std::atomic<std::size_t> next{0};
  std::vector<std::exception_ptr> errors;
  std::mutex mu;
  std::condition_variable cv;
  std::atomic<std::size_t> done{0};  // indices finished (changed under mu)
};

}  // namespace internal

// Runs fn(i) for every i < n on at most max_threads threads (the caller and pool helpers). The
// calls must not share mutable state. When calls throw, the exception of the lowest index is
// rethrown after all have run (as a loop in order would report it first).
template <typename F>
void ParallelFor(std::size_t n, F&& fn,
                 unsigned max_threads = std::thread::hardware_concurrency()) {
  if (n == 0) return;
  auto state = std::make_shared<internal::ParallelState>(n);
  // Claims and runs indices until none is left; every claimed index is counted done.
  auto work = [state, &fn] {
    for (std::size_t i = state->next.fetch_add(1); i < state->n; i = state->next.fetch_add(1)) {
      try {
        fn(i);
      } catch (...) {
        state->errors[i] = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(state->mu);
      if (++state->done == state->n) state->cv.notify_all();
    }
  };
  if (max_threads > 1 && n > 1) {
    auto& pool = internal::WorkerPool::Instance();
    const std::size_t helpers =
        std::min({n - 1, static_cast<std::size_t>(max_threads - 1), pool.size()});
    // A helper that starts after the caller has taken every index finds none and returns at
    // once; `fn` is only touched for a claimed index, while the caller still waits below.
    for (std::size_t k = 0; k < helpers; ++k) {
      if (!pool.Post(work)) break;
    }
  }
  work();
  auto finished = [&] { return state->done.load() == state->n; };
  for (;;) {
    if (finished()) break;
    if (max_threads > 1 && internal::WorkerPool::Instance().TryRunOne()) continue;
    // The helpers' last indices usually end within microseconds: watch before sleeping.
    if (internal::SpinUntil(
            [&] { return finished() || internal::WorkerPool::Instance().HasQueued(); }))
      continue;
    std::unique_lock<std::mutex> lock(state->mu);
    state->cv.wait_for(lock, std::chrono::microseconds(200),
                       [&] { return state->done == state->n; });
  }
  for (const auto& e : state->errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace km
