// Upload of kinemetric-servo/1 files through the service (server/measurements/servo_kinds.h):
// stored as kind "servo" with the samples and the summary result; bad files refused naming file,
// line, field, and nothing stored.
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <unistd.h>

#include "analysis/core/errors.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/servo/servo_truth.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

TEST(ServoUpload, StoresTheRecordAndItsSummary) {
  const fs::path db =
      fs::temp_directory_path() / ("km-servo-" + std::to_string(::getpid()) + ".db");
  fs::remove(db);
  {
    Service svc(std::make_unique<SqliteStorage>(db.string()), {});
    RegisterBuiltinKinds(svc.measurements());
    std::mt19937 rng(5);
    auto c = servo::truth::JigPlan(120)[0];
    const auto rec = servo::truth::Simulate(servo::truth::Pm600Truth(), c, 2.0, rng);
    const std::string text = servo::truth::ServoText(c, rec);
    const auto up = svc.measurements().Upload(text, "a_ccw.txt");
    EXPECT_TRUE(up.created);
    EXPECT_EQ(up.kind, "servo");
    const auto m = svc.storage().GetMeasurement(up.id);
    ASSERT_TRUE(m.has_value());
    EXPECT_EQ(m->machine_id, "pm600-like");
    EXPECT_EQ(m->test_id, "a");
    EXPECT_EQ(m->direction, "ccw");
    const auto samples = svc.storage().GetSamples(up.id);
    EXPECT_EQ(samples.rows(), 120u);
    EXPECT_EQ(samples.columns.size(), 13u);
    const auto r = svc.measurements().Results(up.id);
    EXPECT_EQ(r["record"], "hexapod");
    EXPECT_EQ(r["samples"], 120);
    EXPECT_NEAR(r["force_max_N"][0].get<double>(), rec.force_N[0][0], 2000.0);
    EXPECT_FALSE(svc.measurements().Upload(text, "again.txt").created);

    const std::string bad =
        text.substr(0, text.find("t_s,")) +
        "t_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,f1,f2,f3,f4,f5,f6\n0,1,2,3,4,5,6,7,8,9,10,11,x\n";
    try {
      svc.measurements().Upload(bad, "bad.txt");
      ADD_FAILURE() << "accepted";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.file(), "bad.txt");
      EXPECT_EQ(e.field(), "f6");
      EXPECT_GT(e.line(), 0u);
    }
    EXPECT_EQ(svc.storage().ListMachines().at(0).measurement_count, 1);
  }
  fs::remove(db);
}

}  // namespace
}  // namespace km::server
