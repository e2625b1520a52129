// Tolerance tables on both storage backends, SQLite and PostgreSQL (tests/unit/server/
// storage_backends.h), with the same answers: versions appended per machine, the same sha256
// as the newest version giving it back, a version read back exactly, writers of two instances
// numbering their versions in turn, stored versions never changed.
#include <gtest/gtest.h>

#include <string>
#include <thread>
#include <vector>

#include "server/storage/storage.h"
#include "tests/unit/server/storage_backends.h"

namespace km::server {
namespace {

using test::Backends;

NewToleranceTable Tolerances(const std::string& machine, const std::string& entries) {
  return {machine, entries, "sha-" + entries};
}

TEST_P(Backends, ToleranceTablesAppendVersionsAndNeverOverwriteThem) {
  auto s = Open();
  EXPECT_FALSE(s->GetToleranceTable("vmc", std::nullopt));
  const auto v1 = s->PutToleranceTable(Tolerances("vmc", R"([{"kind":"dbb"}])"));
  EXPECT_TRUE(v1.created);
  EXPECT_EQ(v1.record.version, 1);
  EXPECT_EQ(v1.record.created_at.size(), 20u);
  const auto same = s->PutToleranceTable(Tolerances("vmc", R"([{"kind":"dbb"}])"));
  EXPECT_FALSE(same.created);
  EXPECT_EQ(same.record.version, 1);
  EXPECT_EQ(same.record.created_at, v1.record.created_at);
  EXPECT_EQ(s->PutToleranceTable(Tolerances("vmc", "[]")).record.version, 2);
  EXPECT_EQ(s->PutToleranceTable(Tolerances("lathe", "[]")).record.version, 1);
  // Back to the first table's entries: a new version (only the newest is compared).
  EXPECT_EQ(s->PutToleranceTable(Tolerances("vmc", R"([{"kind":"dbb"}])")).record.version, 3);
  const auto newest = s->GetToleranceTable("vmc", std::nullopt);
  ASSERT_TRUE(newest);
  EXPECT_EQ(newest->version, 3);
  const auto first = s->GetToleranceTable("vmc", 1);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->machine_id, "vmc");
  EXPECT_EQ(first->tolerances_json, R"([{"kind":"dbb"}])");
  EXPECT_EQ(first->sha256, R"(sha-[{"kind":"dbb"}])");
  EXPECT_FALSE(s->GetToleranceTable("vmc", 4));
  EXPECT_FALSE(s->GetToleranceTable("other", std::nullopt));
  // Kept across a reopen (another instance on the same database).
  auto again = Open();
  EXPECT_EQ(again->GetToleranceTable("vmc", std::nullopt)->version, 3);
  EXPECT_EQ(again->GetToleranceTable("lathe", 1)->tolerances_json, "[]");
}

TEST_P(Backends, ToleranceVersionsOfTwoWritersAreNumberedInTurn) {
  auto a = Open();
  auto b = Open();
  std::vector<std::thread> threads;
  for (int w = 0; w < 2; ++w) {
    threads.emplace_back([&, w] {
      Storage& s = w == 0 ? *a : *b;
      for (int i = 0; i < 10; ++i) {
        s.PutToleranceTable(Tolerances("vmc", "[" + std::to_string(w * 100 + i) + "]"));
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(a->GetToleranceTable("vmc", std::nullopt)->version, 20);
  for (int v = 1; v <= 20; ++v) EXPECT_TRUE(a->GetToleranceTable("vmc", v)) << v;
}

}  // namespace
}  // namespace km::server
