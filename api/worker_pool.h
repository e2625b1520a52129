// The handler threads of the HTTP server: a fixed pool with a bounded queue of new requests.
// A full queue refuses at once (the server answers 503 with Retry-After) instead of waiting;
// continuations of requests already admitted (the next piece of a streamed body) are always
// taken, so an admitted request is never dropped half-way.
//
// A thread that has just finished a task watches the queue a little while (yielding its core to
// others) before it sleeps; while one watches, a new task is taken without waking a sleeping
// thread. Under a stream of short requests the handoff then costs no futex wake-up and no
// sleep (api/worker_pool.cpp).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace km::api {

class WorkerPool {
 public:
  WorkerPool(int threads, std::size_t queue_limit);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // A new request: false when queue_limit tasks are already waiting (or the pool stopped).
  bool TryPost(std::function<void()> task);
  // A continuation of an admitted request: queued whatever the queue length.
  void Post(std::function<void()> task);
  // Finishes the running tasks, drops the waiting ones, joins the threads. Idempotent.
  void Stop();

 private:
  void Work();
  // Watches the queue for a while; the task taken, or none.
  std::function<void()> Watch();
  // Takes the first task (the lock held); none when the queue is empty.
  std::function<void()> TakeLocked();

  std::size_t limit_;
  std::vector<std::thread> threads_;
  std::deque<std::function<void()>> tasks_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::atomic<std::size_t> queued_{0};  // tasks_.size(), readable without the lock
  std::atomic<int> watching_{0};        // threads watching the queue (at most one)
};

}  // namespace km::api
