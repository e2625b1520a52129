// ParallelFor: independent calls fn(0) … fn(n − 1) spread over a few threads (the calling
// thread included). Used where an analysis has independent parts (the tests of a DBB set), so
// that a user waiting for one result gets it sooner on a multi-core machine; the result is the
// same as running the calls in order.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <system_error>
#include <thread>
#include <vector>

namespace km {

// Runs fn(i) for every i < n on at most max_threads threads. The calls must not share mutable
// state. When calls throw, the exception of the lowest index is rethrown after all have run
// (as a loop in order would report it first). If no thread can be started the calls run on the
// calling thread.
template <typename F>
void ParallelFor(std::size_t n, F&& fn,
                 unsigned max_threads = std::thread::hardware_concurrency()) {
  std::vector<std::exception_ptr> errors(n);
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t i = next.fetch_add(1); i < n; i = next.fetch_add(1)) {
      try {
        fn(i);
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
  };
  const std::size_t workers = std::min<std::size_t>(n, std::max(1u, max_threads));
  std::vector<std::thread> threads;
  for (std::size_t k = 1; k < workers; ++k) {
    try {
      threads.emplace_back(work);
    } catch (const std::system_error&) {
      break;  // no more threads: the others (and this one) take the work
    }
  }
  work();
  for (auto& t : threads) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace km
