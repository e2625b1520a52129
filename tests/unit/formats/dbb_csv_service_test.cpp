// A dbb-csv upload through the service into a real SQLite file: stored as a DBB test (kind dbb,
// format dbb-csv) with the result of the kinemetric-dbb/1 file of the same test, and read again
// from its stored bytes by the analyses made later (LoadDbb: trace, CW/CCW pair).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "analysis/core/errors.h"
#include "server/measurements/measurement_service.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

std::string Read(const std::string& relative) {
  std::ifstream in(fs::path(KINEMETRIC_SOURCE_DIR) / relative, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class DbbCsvService : public ::testing::Test {
 protected:
  void SetUp() override {
    db_ = fs::temp_directory_path() / ("km-dbb-csv-" + std::to_string(::getpid()) + ".db");
    fs::remove(db_);
    svc_ =
        std::make_unique<Service>(std::make_unique<SqliteStorage>(db_.string()), ServiceOptions{});
    RegisterBuiltinKinds(svc_->measurements());
  }
  void TearDown() override {
    svc_.reset();
    fs::remove(db_);
  }
  MeasurementService& m() { return svc_->measurements(); }

  fs::path db_;
  std::unique_ptr<Service> svc_;
};

TEST_F(DbbCsvService, StoresTheCsvAsADbbTestWithTheKinemetricFilesResult) {
  const auto txt = m().Upload(Read("data/examples/dbb_xy-r150_ccw.txt"), "ccw.txt");
  const auto csv = m().Upload(Read("tests/fixtures/dbb-csv/dbb_xy-r150_ccw.csv"), "ccw.csv");
  ASSERT_TRUE(csv.created);
  EXPECT_NE(csv.id, txt.id);
  EXPECT_EQ(csv.kind, "dbb");
  const auto rec = svc_->storage().GetMeasurement(csv.id);
  ASSERT_TRUE(rec);
  EXPECT_EQ(rec->kind, "dbb");
  EXPECT_EQ(rec->format, "dbb-csv");
  EXPECT_EQ(rec->machine_id, "vmc-3axis");
  EXPECT_EQ(rec->test_id, "xy-r150");
  EXPECT_EQ(rec->direction, "ccw");
  EXPECT_EQ(m().Results(csv.id).dump(), m().Results(txt.id).dump());
  // The same bytes again: found by their hash, not stored twice.
  EXPECT_FALSE(m().Upload(Read("tests/fixtures/dbb-csv/dbb_xy-r150_ccw.csv"), "again.csv").created);
}

TEST_F(DbbCsvService, TheStoredCsvIsReadAgainForTheTraceAndThePair) {
  const auto txt = m().Upload(Read("data/examples/dbb_xy-r150_ccw.txt"), "ccw.txt");
  const auto csv = m().Upload(Read("tests/fixtures/dbb-csv/dbb_xy-r150_ccw.csv"), "ccw.csv");
  const auto cw = m().Upload(Read("data/examples/dbb_xy-r150_cw.txt"), "cw.txt");
  const dbb::DbbTest a = m().LoadDbb(txt.id), b = m().LoadDbb(csv.id);
  EXPECT_EQ(b.angle_deg, a.angle_deg);
  EXPECT_EQ(b.dr_um, a.dr_um);
  EXPECT_EQ(m().DbbTrace(csv.id).dump(), m().DbbTrace(txt.id).dump());
  const auto pair_csv = m().DbbPairJson(csv.id), pair_txt = m().DbbPairJson(txt.id);
  EXPECT_EQ(pair_csv["partner_id"], nlohmann::json(cw.id));
  EXPECT_EQ(pair_csv["pair"].dump(), pair_txt["pair"].dump());
}

TEST_F(DbbCsvService, ABadCsvIsRefusedNamingFileLineAndField) {
  std::string bad = Read("tests/fixtures/dbb-csv/dbb_xy-r150_ccw.csv");
  bad.replace(bad.find("feed_mm_min,1000"), 16, "feed_mm_min,fast");
  try {
    m().Upload(bad, "bad.csv");
    FAIL() << "accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "bad.csv");
    EXPECT_EQ(e.line(), 9u);
    EXPECT_EQ(e.field(), "feed_mm_min");
  }
  EXPECT_EQ(svc_->storage().ListMachines().size(), 0u);
}

}  // namespace
}  // namespace km::server
