#include "server/sqlite_storage.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>

#include "analysis/core/errors.h"
#include "server/time_util.h"

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
  std::int64_t id = 0;
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
  EXPECT_THROW(s.GetRaw(999), NotFound);
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
  EXPECT_EQ(NormalizeIso8601("2026-11-20T10:00:00+01:00"), "2026-11-20T09:00:00Z");
  EXPECT_EQ(NormalizeIso8601("2026-11-20"), "2026-11-20T00:00:00Z");
  EXPECT_EQ(NormalizeIso8601("2026-11-20 23:30-02:30"), "2026-11-21T02:00:00Z");
  EXPECT_FALSE(NormalizeIso8601("2026-13-01").has_value());
  EXPECT_FALSE(NormalizeIso8601("soon").has_value());
}

}  // namespace
}  // namespace km::server
