#include "server/storage/sqlite/sqlite_storage.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <map>

#include "analysis/core/errors.h"
#include "server/base/time_util.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

class StorageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = fs::temp_directory_path() /
            ("km-storage-" + std::to_string(::getpid()) + "-" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db");
    fs::remove(path_);
  }
  void TearDown() override {
    for (const char* ext : {"", "-wal", "-shm"}) fs::remove(path_.string() + ext);
  }
  NewMeasurement Sample(const std::string& sha, const std::string& machine) {
    NewMeasurement m;
    m.sha256 = sha;
    m.kind = "dbb";
    m.format = "kinemetric-dbb/1";
    m.machine_id = machine;
    m.test_id = "t";
    m.direction = "ccw";
    m.measured_at = "2026-01-0" + std::to_string(1 + (sha[0] % 8)) + "T00:00:00Z";
    m.metadata_json = "{}";
    m.raw = "raw bytes " + sha;
    m.samples.columns = {"a", "b"};
    m.samples.values = {1, 2, 3, 4, 5, 6};
    return m;
  }
  fs::path path_;
};

TEST_F(StorageTest, StoresOnceAndKeepsEverythingAcrossReopen) {
  MeasurementId id;
  {
    SqliteStorage s(path_.string());
    const auto a = s.PutMeasurement(Sample("a1", "m1"), {{"dbb", "dbb/1", R"({"x":1})"}});
    EXPECT_TRUE(a.created);
    id = a.id;
    const auto again = s.PutMeasurement(Sample("a1", "m1"), {{"dbb", "dbb/1", R"({"x":2})"}});
    EXPECT_FALSE(again.created);
    EXPECT_EQ(again.id, id);
    s.PutMeasurement(Sample("b2", "m2"), {});
  }
  SqliteStorage s(path_.string());
  const auto rec = s.GetMeasurement(id);
  ASSERT_TRUE(rec);
  EXPECT_EQ(rec->machine_id, "m1");
  EXPECT_EQ(rec->sample_count, 3);
  EXPECT_EQ(s.GetRaw(id), "raw bytes a1");
  const auto block = s.GetSamples(id);
  EXPECT_EQ(block.Column(1), (std::vector<double>{2, 4, 6}));
  const auto results = s.GetResults(id);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].result_json, R"({"x":1})");  // the first stored result is kept
  EXPECT_EQ(results[0].input_sha256, "a1");
  EXPECT_EQ(s.ListMachines().size(), 2u);
  MeasurementFilter f;
  f.machine_id = "m2";
  EXPECT_EQ(s.ListMeasurements(f).total, 1);
  EXPECT_THROW(s.GetRaw(MeasurementId(999)), NotFound);
}

TEST_F(StorageTest, MeasurementsAreImmutableInTheDatabaseItself) {
  {
    SqliteStorage s(path_.string());
    s.PutMeasurement(Sample("c3", "m"), {});
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  EXPECT_NE(sqlite3_exec(db, "UPDATE measurements SET machine_id='x'", nullptr, nullptr, nullptr),
            SQLITE_OK);
  EXPECT_NE(sqlite3_exec(db, "DELETE FROM measurements", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  SqliteStorage s(path_.string());
  EXPECT_EQ(s.ListMachines().at(0).machine_id, "m");
}

TEST_F(StorageTest, RefusesANewerSchema) {
  { SqliteStorage s(path_.string()); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  sqlite3_exec(db, "PRAGMA user_version=99", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  EXPECT_THROW(SqliteStorage s(path_.string()), Error);
}

TEST_F(StorageTest, SampleBlobRoundTripAndCorruption) {
  SampleBlock b;
  b.columns = {"angle_deg", "dr_um"};
  b.values = {0.0, -1.25, 0.1, 3.5e-7};
  const auto back = DecodeSamples(EncodeSamples(b));
  EXPECT_EQ(back.columns, b.columns);
  EXPECT_EQ(back.values, b.values);
  auto blob = EncodeSamples(b);
  blob.pop_back();
  EXPECT_THROW(DecodeSamples(blob), Error);
}

TEST(TimeUtil, NormalisesIso8601ToUtc) {
  EXPECT_EQ(NormaliseIso8601("2026-11-20T10:00:00+01:00"), "2026-11-20T09:00:00Z");
  EXPECT_EQ(NormaliseIso8601("2026-11-20"), "2026-11-20T00:00:00Z");
  EXPECT_EQ(NormaliseIso8601("2026-11-20 23:30-02:30"), "2026-11-21T02:00:00Z");
  EXPECT_FALSE(NormaliseIso8601("2026-13-01").has_value());
  EXPECT_FALSE(NormaliseIso8601("soon").has_value());
}

TEST_F(StorageTest, ListsPageNewestFirstAndFindByFreeTextAndId) {
  SqliteStorage s(path_.string());
  // 12 tests of one machine measured one per day, uploaded in a shuffled order; one of another.
  const int day_of[] = {7, 2, 11, 5, 1, 9, 3, 12, 8, 4, 10, 6};
  std::map<int, MeasurementId> id_of_day;
  for (const int day : day_of) {
    NewMeasurement m = Sample("s" + std::to_string(day), "m1");
    m.measured_at =
        "2026-03-" + std::string(day < 10 ? "0" : "") + std::to_string(day) + "T08:00:00Z";
    m.filename = "Run_" + std::to_string(day) + (day % 2 ? "_CW.txt" : "_ccw.txt");
    m.direction = day % 2 ? "cw" : "ccw";
    m.kind = day == 12 ? "straightness" : "dbb";
    id_of_day[day] = s.PutMeasurement(m, {}).id;
  }
  s.PutMeasurement(Sample("other", "m2"), {});
  MeasurementFilter f;
  f.machine_id = "m1";
  f.order = MeasurementFilter::Order::kNewest;
  f.limit = 5;
  auto page = s.ListMeasurements(f);
  EXPECT_EQ(page.total, 12);
  ASSERT_EQ(page.items.size(), 5u);
  for (int k = 0; k < 5; ++k) EXPECT_EQ(page.items[k].id, id_of_day[12 - k]) << k;
  f.offset = 10;
  page = s.ListMeasurements(f);
  ASSERT_EQ(page.items.size(), 2u);  // the last page: days 2 and 1
  EXPECT_EQ(page.items[0].id, id_of_day[2]);
  EXPECT_EQ(page.items[1].id, id_of_day[1]);
  // Oldest first (the default) and newest upload first.
  f.offset = 0;
  f.order = MeasurementFilter::Order::kOldest;
  EXPECT_EQ(s.ListMeasurements(f).items[0].id, id_of_day[1]);
  f.order = MeasurementFilter::Order::kUploaded;
  EXPECT_EQ(s.ListMeasurements(f).items[0].id, id_of_day[6]);  // the last one stored
  // Free text, case-insensitive, over name, test, direction and kind; an id as "#N" or "N".
  f.limit = 50;
  f.text = "_cw";
  page = s.ListMeasurements(f);
  EXPECT_EQ(page.total, 6);
  for (const auto& r : page.items) EXPECT_EQ(r.direction, "cw") << r.filename;
  f.text = "STRAIGHT";
  page = s.ListMeasurements(f);
  ASSERT_EQ(page.total, 1);
  EXPECT_EQ(page.items[0].id, id_of_day[12]);
  f.text = "#" + to_string(id_of_day[9]);
  page = s.ListMeasurements(f);
  ASSERT_EQ(page.total, 1);
  EXPECT_EQ(page.items[0].id, id_of_day[9]);
  f.text = "no such thing";
  EXPECT_EQ(s.ListMeasurements(f).total, 0);
  f.text = "%";  // taken as the character, not as a wildcard
  EXPECT_EQ(s.ListMeasurements(f).total, 0);
  f.text = "n_1";  // "_" is a character too: "Run_1…" does not match "n_1" with any letter
  EXPECT_EQ(s.ListMeasurements(f).total, 4);  // Run_1_CW, Run_10, Run_11_CW, Run_12
  // Filters combine: kind and a date range (from inclusive, to exclusive).
  f.text.reset();
  f.order = MeasurementFilter::Order::kOldest;
  f.kind = "dbb";
  f.from = "2026-03-03T08:00:00Z";
  f.to = "2026-03-06T08:00:00Z";
  page = s.ListMeasurements(f);
  ASSERT_EQ(page.total, 3);
  EXPECT_EQ(page.items[0].id, id_of_day[3]);
  EXPECT_EQ(page.items[2].id, id_of_day[5]);
}

TEST_F(StorageTest, AMachineListIsAnsweredFromAnIndex) {
  SqliteStorage s(path_.string());
  s.PutMeasurement(Sample("i1", "m1"), {});
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.string().c_str(), &db), SQLITE_OK);
  std::string plan;
  const char* sql =
      "EXPLAIN QUERY PLAN SELECT id FROM measurements WHERE machine_id = 'm1' "
      "ORDER BY COALESCE(measured_at, uploaded_at) DESC, id DESC LIMIT 50";
  sqlite3_exec(
      db, sql,
      [](void* out, int n, char** values, char**) {
        for (int i = 0; i < n; ++i) *static_cast<std::string*>(out) += values[i] ? values[i] : "";
        *static_cast<std::string*>(out) += "\n";
        return 0;
      },
      &plan, nullptr);
  sqlite3_close(db);
  EXPECT_NE(plan.find("measurements_by_machine_time"), std::string::npos) << plan;
  EXPECT_EQ(plan.find("TEMP B-TREE"), std::string::npos) << "no sort of every row: " << plan;
}

}  // namespace
}  // namespace km::server
