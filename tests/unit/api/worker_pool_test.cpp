#include "api/worker_pool.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include <gtest/gtest.h>

namespace km::api {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

// Waits until `done` reaches `want` or the deadline passes; the count reached.
int WaitForCount(std::atomic<int>& done, int want, milliseconds deadline) {
  const auto until = std::chrono::steady_clock::now() + deadline;
  while (done.load() < want && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(microseconds(200));
  }
  return done.load();
}

// Tasks posted at every spacing around the time a finished thread watches the queue (100 µs)
// are all run: a task posted just as the watching thread gives up and goes to sleep is not
// left in the queue. A lost wake-up leaves the count short until the next post; here there is
// none after the last, so it would stay short.
TEST(WorkerPool, TasksPostedAroundTheWatchAreAllRun) {
  for (int threads : {1, 2, 8}) {
    WorkerPool pool(threads, 1000);
    std::atomic<int> done{0};
    int posted = 0;
    for (int spacing_us : {0, 20, 60, 90, 100, 110, 150, 300}) {
      for (int k = 0; k < 40; ++k) {
        ASSERT_TRUE(pool.TryPost([&] { done.fetch_add(1); }));
        ++posted;
        if (spacing_us > 0) std::this_thread::sleep_for(microseconds(spacing_us));
      }
      EXPECT_EQ(WaitForCount(done, posted, milliseconds(5000)), posted)
          << threads << " threads, posts " << spacing_us << " µs apart";
    }
  }
}

// Continuations posted from inside tasks (as a streamed body's next piece is) are run too.
TEST(WorkerPool, ContinuationsFromTasksAreRun) {
  WorkerPool pool(2, 4);
  std::atomic<int> done{0};
  std::function<void(int)> chain = [&](int left) {
    done.fetch_add(1);
    if (left > 0) pool.Post([&, left] { chain(left - 1); });
  };
  pool.Post([&] { chain(499); });
  EXPECT_EQ(WaitForCount(done, 500, milliseconds(5000)), 500);
}

// The queue of new requests is bounded: with every thread busy, queue_limit tasks wait and the
// next is refused; continuations are always taken. Once the threads are free all are run.
TEST(WorkerPool, AFullQueueRefusesNewTasksButTakesContinuations) {
  WorkerPool pool(1, 2);
  std::mutex mu;
  std::condition_variable cv;
  bool release = false, started = false;
  std::atomic<int> done{0};
  ASSERT_TRUE(pool.TryPost([&] {
    std::unique_lock lock(mu);
    started = true;
    cv.notify_all();
    cv.wait(lock, [&] { return release; });
    done.fetch_add(1);
  }));
  {
    std::unique_lock lock(mu);
    cv.wait(lock, [&] { return started; });
  }
  EXPECT_TRUE(pool.TryPost([&] { done.fetch_add(1); }));
  EXPECT_TRUE(pool.TryPost([&] { done.fetch_add(1); }));
  EXPECT_FALSE(pool.TryPost([&] { done.fetch_add(1); }));
  pool.Post([&] { done.fetch_add(1); });
  {
    std::lock_guard lock(mu);
    release = true;
  }
  cv.notify_all();
  EXPECT_EQ(WaitForCount(done, 4, milliseconds(5000)), 4);
}

// A pool stopped while idle (a thread possibly watching the queue) ends at once.
TEST(WorkerPool, StopsWhileAThreadWatches) {
  for (int k = 0; k < 50; ++k) {
    WorkerPool pool(2, 8);
    std::atomic<int> done{0};
    ASSERT_TRUE(pool.TryPost([&] { done.fetch_add(1); }));
    std::this_thread::sleep_for(microseconds(k * 3));
    pool.Stop();
    EXPECT_FALSE(pool.TryPost([&] { done.fetch_add(1); }));
    EXPECT_LE(done.load(), 1);
  }
}

}  // namespace
}  // namespace km::api
