#include "server/reports/render_gate.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(__linux__)
#include <sys/resource.h>
#include <unistd.h>
#endif

namespace km::server {

RenderGate::RenderGate(RenderGateOptions options) : options_(options) {
  options_.max_running = std::max(1, options_.max_running);
  if (options_.max_waiting < 0) options_.max_waiting = options_.max_running;
  for (int i = 0; i < options_.max_running; ++i) threads_.emplace_back([this] { Work(); });
}

RenderGate::~RenderGate() {
  Stop(Clock::now());
  cv_.notify_all();
  for (auto& t : threads_) t.join();
}

std::string RenderGate::Run(Job job) {
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

void RenderGate::Stop(Clock::time_point cancel_at) {
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

int RenderGate::running() const {
  std::lock_guard lock(mu_);
  return running_;
}

std::size_t RenderGate::waiting() const {
  std::lock_guard lock(mu_);
  return queue_.size();
}

bool RenderGate::Cancelled() const {
  return stop_requested_.load() && Clock::now().time_since_epoch().count() >= cancel_at_.load();
}

void RenderGate::Refuse(Task& t, const std::string& why) {
  t.done.set_exception(std::make_exception_ptr(Unavailable(why)));
}

void RenderGate::Work() {
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
