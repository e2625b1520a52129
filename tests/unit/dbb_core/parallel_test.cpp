// ParallelFor: every index runs exactly once, on several threads; the exception of the lowest
// failing index is the one reported, after all calls have run; one thread runs in order.
#include "analysis/core/parallel.h"

#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace km {
namespace {

TEST(ParallelFor, RunsEveryIndexOnceOnSeveralThreads) {
  std::vector<std::atomic<int>> hits(1000);
  std::mutex m;
  std::set<std::thread::id> ids;
  ParallelFor(
      hits.size(),
      [&](std::size_t i) {
        hits[i].fetch_add(1);
        std::lock_guard<std::mutex> lock(m);
        ids.insert(std::this_thread::get_id());
      },
      4);
  for (const auto& h : hits) EXPECT_EQ(h.load(), 1);
  EXPECT_GE(ids.size(), 1u);
  EXPECT_LE(ids.size(), 4u);
}

TEST(ParallelFor, ReportsTheLowestFailingIndexAfterAllRan) {
  std::atomic<int> ran{0};
  try {
    ParallelFor(
        64,
        [&](std::size_t i) {
          ran.fetch_add(1);
          if (i == 7 || i == 40) throw std::runtime_error("index " + std::to_string(i));
        },
        3);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "index 7");
  }
  EXPECT_EQ(ran.load(), 64);
}

TEST(ParallelFor, OneThreadRunsInOrderOnTheCaller) {
  std::vector<std::size_t> order;
  const auto caller = std::this_thread::get_id();
  ParallelFor(
      10,
      [&](std::size_t i) {
        EXPECT_EQ(std::this_thread::get_id(), caller);
        order.push_back(i);
      },
      1);
  ASSERT_EQ(order.size(), 10u);
  for (std::size_t i = 0; i < 10; ++i) EXPECT_EQ(order[i], i);
  ParallelFor(
      0, [&](std::size_t) { FAIL(); }, 4);
}

}  // namespace
}  // namespace km
