// The handler threads of the HTTP server: a fixed pool with a bounded queue of new requests.
// A full queue refuses at once (the server answers 503 with Retry-After) instead of waiting;
// continuations of requests already admitted (the next piece of a streamed body) are always
// taken, so an admitted request is never dropped half-way.
#pragma once

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

  std::size_t limit_;
  std::vector<std::thread> threads_;
  std::deque<std::function<void()>> tasks_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
};

}  // namespace km::api
