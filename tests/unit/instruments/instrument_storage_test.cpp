// The instrument register on both storage backends, SQLite and PostgreSQL (tests/unit/server/
// storage_backends.h), with the same answers: versions appended per serial, the same sha256 as
// the newest version giving it back, a version read back exactly, the list holding the newest
// version of each serial by serial, writers of two instances numbering their versions in turn.
#include <gtest/gtest.h>

#include <string>
#include <thread>
#include <vector>

#include "server/storage/storage.h"
#include "tests/unit/server/storage_backends.h"

namespace km::server {
namespace {

using test::Backends;

NewInstrumentVersion Entry(const std::string& serial, const std::string& doc) {
  return {serial, doc, "sha-" + doc};
}

TEST_P(Backends, InstrumentVersionsAreAppendedAndNeverOverwritten) {
  auto s = Open();
  EXPECT_FALSE(s->GetInstrument("XL80-1", std::nullopt));
  EXPECT_TRUE(s->ListInstruments().empty());
  const auto v1 = s->PutInstrument(Entry("XL80-1", R"({"kind":"laser"})"));
  EXPECT_TRUE(v1.created);
  EXPECT_EQ(v1.record.version, 1);
  EXPECT_EQ(v1.record.created_at.size(), 20u);
  const auto same = s->PutInstrument(Entry("XL80-1", R"({"kind":"laser"})"));
  EXPECT_FALSE(same.created);
  EXPECT_EQ(same.record.version, 1);
  EXPECT_EQ(same.record.created_at, v1.record.created_at);
  EXPECT_EQ(s->PutInstrument(Entry("XL80-1", "{}")).record.version, 2);
  EXPECT_EQ(s->PutInstrument(Entry("QC20-7", "{}")).record.version, 1);
  EXPECT_EQ(s->PutInstrument(Entry("XL80-1", R"({"kind":"laser"})")).record.version, 3);
  const auto newest = s->GetInstrument("XL80-1", std::nullopt);
  ASSERT_TRUE(newest);
  EXPECT_EQ(newest->version, 3);
  const auto first = s->GetInstrument("XL80-1", 1);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->serial, "XL80-1");
  EXPECT_EQ(first->instrument_json, R"({"kind":"laser"})");
  EXPECT_EQ(first->sha256, R"(sha-{"kind":"laser"})");
  EXPECT_FALSE(s->GetInstrument("XL80-1", 4));
  EXPECT_FALSE(s->GetInstrument("xl80-1", std::nullopt));  // serials are exact
  const auto list = s->ListInstruments();
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].serial, "QC20-7");
  EXPECT_EQ(list[0].version, 1);
  EXPECT_EQ(list[1].serial, "XL80-1");
  EXPECT_EQ(list[1].version, 3);
  // Kept across a reopen (another instance on the same database).
  auto again = Open();
  EXPECT_EQ(again->GetInstrument("XL80-1", std::nullopt)->version, 3);
  EXPECT_EQ(again->GetInstrument("QC20-7", 1)->instrument_json, "{}");
}

TEST_P(Backends, InstrumentVersionsOfTwoWritersAreNumberedInTurn) {
  auto a = Open();
  auto b = Open();
  std::vector<std::thread> threads;
  for (int w = 0; w < 2; ++w) {
    threads.emplace_back([&, w] {
      Storage& s = w == 0 ? *a : *b;
      for (int i = 0; i < 10; ++i) {
        s.PutInstrument(Entry("XL80-1", "{\"n\":" + std::to_string(w * 100 + i) + "}"));
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(a->GetInstrument("XL80-1", std::nullopt)->version, 20);
  for (int v = 1; v <= 20; ++v) EXPECT_TRUE(a->GetInstrument("XL80-1", v)) << v;
}

}  // namespace
}  // namespace km::server
