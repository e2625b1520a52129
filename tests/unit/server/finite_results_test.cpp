// Values so large that the analysis overflows (1e308 µm, 1e200 mm) are refused at upload as bad
// input naming the file, never stored as results full of nulls; physically absurd magnitudes are
// refused before the analysis, naming the line and the column.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "analysis/core/errors.h"
#include "ingest/tracker_parser.h"
#include "server/base/finite_result.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/temp_dir.h"
#include "tests/unit/tracker/tracker_test_util.h"

namespace km::server {
namespace {

std::string Straightness(const std::string& bad_row = "", int at = 20) {
  std::string s =
      "# format: kinemetric-straightness/1\n# machine_id: vmc\n# axis: X\n# error_direction: Y\n"
      "# sensor: capacitance\n# reference: straightedge\nposition_mm,deviation_um\n";
  for (int i = 0; i < 40; ++i) {
    s += (i == at && !bad_row.empty())
             ? bad_row + "\n"
             : std::to_string(5 * i) + "," + std::to_string(std::sin(0.3 * i)) + "\n";
  }
  return s;
}

std::string Parallelism(const std::string& bad_row = "") {
  std::string s =
      "# format: kinemetric-parallelism/1\n# machine_id: vmc\n# axis: X\n# datum: t_slot\n"
      "position_mm,deviation_um\n";
  for (int i = 0; i < 20; ++i) {
    s += (i == 10 && !bad_row.empty())
             ? bad_row + "\n"
             : std::to_string(10 * i) + "," + std::to_string(0.05 * i) + "\n";
  }
  return s;
}

std::string Flatness(const std::string& bad_row = "") {
  std::string s =
      "# format: kinemetric-flatness/1\n# machine_id: vmc\n# datum: table\nx_mm,y_mm,z_um\n";
  int k = 0;
  for (int x = 0; x < 6; ++x) {
    for (int y = 0; y < 6; ++y, ++k) {
      s += (k == 14 && !bad_row.empty()) ? bad_row + "\n"
                                         : std::to_string(50 * x) + "," + std::to_string(50 * y) +
                                               "," + std::to_string(0.01 * x * y) + "\n";
    }
  }
  return s;
}

std::string Dbb(const std::string& bad_row = "") {
  std::string s =
      "# format: kinemetric-dbb/1\n# machine_id: vmc\n# test_id: xy\n# direction: ccw\n"
      "# bar_length_mm: 150\n# centre_mm: 0, 0, 0\n# feed_mm_min: 1000\nangle_deg,dr_um\n";
  for (int i = 0; i < 72; ++i) {
    s += (i == 30 && !bad_row.empty())
             ? bad_row + "\n"
             : std::to_string(5 * i) + "," + std::to_string(std::cos(0.1 * i)) + "\n";
  }
  return s;
}

tracker::TrackerReadings TrackerSurvey() {
  const auto o = tracker::test::MakeSetup(400.0, 4, 4, 5);
  return tracker::SimulateTrackerSurvey(o).readings;
}

class FiniteResults : public test::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    svc_ =
        std::make_unique<Service>(std::make_unique<SqliteStorage>(Path("k.db")), ServiceOptions{});
    RegisterBuiltinKinds(svc_->measurements());
  }
  void TearDown() override {
    svc_.reset();
    TempDirTest::TearDown();
  }
  // The upload is refused as bad input naming the file (and `field` when not empty); nothing is
  // stored.
  void ExpectRefused(const std::string& bytes, const std::string& field = "", std::size_t line = 0,
                     bool too_large = true) {
    const auto before = svc_->storage().ListMeasurements({}).total;
    try {
      const auto out = svc_->measurements().Upload(bytes, "huge.txt");
      ADD_FAILURE() << "stored as " << out.id << ": "
                    << svc_->measurements().Results(out.id).dump();
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.file(), "huge.txt") << e.what();
      if (!field.empty()) {
        EXPECT_EQ(e.field(), field) << e.what();
      }
      if (line) {
        EXPECT_EQ(e.line(), line) << e.what();
      }
      if (too_large) {
        EXPECT_NE(std::string(e.what()).find("too large"), std::string::npos) << e.what();
      }
    }
    EXPECT_EQ(svc_->storage().ListMeasurements({}).total, before);
  }
  std::unique_ptr<Service> svc_;
};

TEST_F(FiniteResults, OrdinaryFilesOfEveryKindAreStored) {
  for (const auto& text : {Straightness(), Parallelism(), Flatness(), Dbb(),
                           ingest::WriteTrackerFile(TrackerSurvey())}) {
    const auto out = svc_->measurements().Upload(text, "ok.txt");
    EXPECT_TRUE(out.created) << out.kind;
    auto result = svc_->measurements().Results(out.id);
    EXPECT_TRUE(result["instrument"].is_null()) << out.kind;  // the files name no instrument
    result.erase("instrument");
    EXPECT_EQ(result.dump().find("null"), std::string::npos) << out.kind;
  }
}

TEST_F(FiniteResults, HugeDeviationsAreRefused) {
  ExpectRefused(Straightness("100,1e308"), "deviation_um", 28);
  ExpectRefused(Straightness("100,-1e200"), "deviation_um", 28);
  ExpectRefused(Straightness("100,2e6"), "deviation_um", 28);     // 2 m off a straight line
  ExpectRefused(Straightness("1e300,0", 39), "position_mm", 47);  // the last row
  ExpectRefused(Parallelism("95,1e308"), "deviation_um", 16);
  ExpectRefused(Flatness("100,100,1e308"), "z_um", 19);
  ExpectRefused(Flatness("5e6,100,0"), "x_mm", 19);  // 5 km
  ExpectRefused(Flatness("100,-5e6,0"), "y_mm", 19);
  // Coordinates that overflow the parser's own checks are refused there, for another reason.
  ExpectRefused(Flatness("1e300,100,0"), "", 0, false);
  ExpectRefused(Flatness("100,-1e300,0"), "", 0, false);
  ExpectRefused(Dbb("150,1e308"), "dr_um", 39);
  ExpectRefused(Dbb("150,-1e200"), "dr_um", 39);
}

// The survey file with column `column` of data row `row` replaced by `value`.
std::string TrackerFileWith(std::size_t row, std::size_t column, const std::string& value) {
  const std::string text = ingest::WriteTrackerFile(TrackerSurvey());
  std::size_t at = text.find("\n", text.find("point,x_mm")) + 1;
  for (std::size_t r = 0; r < row; ++r) at = text.find('\n', at) + 1;
  for (std::size_t c = 0; c < column; ++c) at = text.find(',', at) + 1;
  const std::size_t end = text.find_first_of(",\n", at);
  return text.substr(0, at) + value + text.substr(end);
}

TEST_F(FiniteResults, HugeTrackerReadingsAreRefused) {
  ExpectRefused(TrackerFileWith(7, 6, "1e300"), "d3_um");
  ExpectRefused(TrackerFileWith(7, 6, "-2e12"), "d3_um");  // 2 km further away
  ExpectRefused(TrackerFileWith(3, 2, "1e200"), "y_mm");
  ExpectRefused(TrackerFileWith(0, 3, "-1e300"), "z_mm");
  ExpectRefused(TrackerFileWith(3, 1, "5e9"), "x_mm");
}

TEST(FiniteResult, NamesTheFirstNonFiniteNumber) {
  nlohmann::json ok = {{"a", 1.5}, {"b", {1, 2, nullptr}}, {"c", "text"}};
  EXPECT_NO_THROW(RequireFiniteResult(ok, "f.txt"));
  nlohmann::json bad = ok;
  bad["b"][1] = std::numeric_limits<double>::quiet_NaN();
  try {
    RequireFiniteResult(bad, "f.txt");
    FAIL() << "accepted NaN";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "f.txt");
    EXPECT_EQ(e.field(), "b[1]");
    EXPECT_NE(std::string(e.what()).find("too large to analyse"), std::string::npos);
  }
  nlohmann::json deep;
  deep["tests"][0]["centre_offset_um"] = {0.0, std::numeric_limits<double>::infinity()};
  try {
    RequireFiniteResult(deep, "g.txt");
    FAIL() << "accepted infinity";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "tests[0].centre_offset_um[1]");
  }
}

}  // namespace
}  // namespace km::server
