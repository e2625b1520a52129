// The tolerance tables through the service (server/tolerances/tolerance_service.h): versions
// 1, 2, …, the same entries again giving the newest version back, GET of a version; and the
// conformance of the example DBB tests of vmc-3axis judged on the fly from the newest table —
// in the upload answer, the measurement, its results, every item of the list and its PDF —
// changing when the table changes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <memory>
#include <sstream>

#include "analysis/core/errors.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/expect_error.h"
#include "tests/unit/server/pdf_text.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string ExampleFile(const std::string& name) {
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/" + name);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

json Body(const json& entries) {
  return {{"tolerances", entries}};
}
json Body(std::initializer_list<json> entries) {
  json list = json::array();
  for (const auto& e : entries) list.push_back(e);
  return Body(list);
}

json GTol(double tolerance, const std::string& test_id = "") {
  json e = {{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"tolerance", tolerance}};
  if (!test_id.empty()) e["test_id"] = test_id;
  return e;
}

class ToleranceServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("km-tolerances-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    svc_ = std::make_unique<Service>(std::make_unique<SqliteStorage>((dir_ / "km.db").string()),
                                     ServiceOptions{});
    RegisterBuiltinKinds(svc_->measurements());
  }
  void TearDown() override {
    svc_.reset();
    fs::remove_all(dir_);
  }
  std::string PdfText(const std::string& pdf) {
    return ::km::test::PdfToText(pdf, (dir_ / "r.pdf").string());
  }
  fs::path dir_;
  std::unique_ptr<Service> svc_;
};

TEST_F(ToleranceServiceTest, VersionsAreAppendedAndTheSameEntriesGiveTheNewestBack) {
  auto& t = svc_->tolerances();
  EXPECT_THROW(t.Get("vmc", std::nullopt), NotFound);
  const auto v1 = t.Put("vmc", Body({GTol(15), GTol(10, "xy-r150")}));
  EXPECT_EQ(v1["version"], 1);
  EXPECT_EQ(v1["created"], true);
  EXPECT_EQ(v1["machine_id"], "vmc");
  EXPECT_EQ(v1["created_at"].get<std::string>().size(), 20u);
  ASSERT_EQ(v1["tolerances"].size(), 2u);
  EXPECT_EQ(v1["tolerances"][1]["test_id"], "xy-r150");
  // The same entries, in another order: version 1 again, nothing stored.
  const auto again = t.Put("vmc", Body({GTol(10, "xy-r150"), GTol(15)}));
  EXPECT_EQ(again["version"], 1);
  EXPECT_EQ(again["created"], false);
  EXPECT_EQ(again["tolerances"], v1["tolerances"]);
  const auto v2 = t.Put("vmc", Body({GTol(12)}));
  EXPECT_EQ(v2["version"], 2);
  EXPECT_EQ(v2["created"], true);
  const auto v3 = t.Put("vmc", Body(json::array()));  // no tolerances, as a version of its own
  EXPECT_EQ(v3["version"], 3);
  EXPECT_TRUE(v3["tolerances"].empty());
  EXPECT_EQ(t.Get("vmc", std::nullopt)["version"], 3);
  EXPECT_EQ(t.Get("vmc", 1)["tolerances"], v1["tolerances"]);
  EXPECT_FALSE(t.Get("vmc", 1).contains("created"));
  EXPECT_TRUE(test::Contains(test::Expect<NotFound>([&] { t.Get("vmc", 4); }).what(),
                             "the newest is version 3"));
  EXPECT_THROW(t.Get("lathe", std::nullopt), NotFound);  // another machine's tables are its own
  EXPECT_EQ(t.Put("lathe", Body({GTol(15)}))["version"], 1);
  EXPECT_EQ(test::Expect<InvalidInput>([&] { t.Put("a/b", Body({})); }).field(), "machine_id");
  EXPECT_EQ(test::Expect<InvalidInput>([&] { t.Put("vmc", Body({GTol(-1)})); }).field(),
            "tolerances[0].tolerance");
  EXPECT_EQ(t.Get("vmc", std::nullopt)["version"], 3);  // a refused table stores nothing
}

TEST_F(ToleranceServiceTest, MeasurementsAreJudgedOnTheFlyFromTheNewestTable) {
  auto& m = svc_->measurements();
  const std::string ccw_file = ExampleFile("dbb_xy-r150_ccw.txt");
  ASSERT_FALSE(ccw_file.empty());
  const auto up = m.Upload(ccw_file, "ccw.txt");
  ASSERT_TRUE(up.created);
  EXPECT_EQ(up.conformance["verdict"], "no tolerance");
  EXPECT_TRUE(up.conformance["tolerance_version"].is_null());
  const double g = m.Results(up.id)["iso230_4"]["circular_deviation_um"].get<double>();
  EXPECT_FALSE(m.Results(up.id).contains("conformance"));  // the object the command prints

  // G within its tolerance: pass everywhere a measurement is answered.
  svc_->tolerances().Put("vmc-3axis", Body({GTol(g + 0.5, "xy-r150")}));
  const auto list = m.ListMeasurements({});
  ASSERT_EQ(list["items"].size(), 1u);
  EXPECT_EQ(list["items"][0]["conformance"]["verdict"], "pass");
  EXPECT_EQ(list["items"][0]["conformance"]["tolerance_version"], 1);
  EXPECT_EQ(list["items"][0]["key_result"]["name"], "circularity_um");
  EXPECT_EQ(m.MeasurementWithSamples(up.id)["conformance"]["verdict"], "pass");
  const auto results = m.ResultsWithConformance(up.id);
  EXPECT_EQ(results["conformance"]["verdict"], "pass");
  EXPECT_EQ(results["conformance"]["figures"][0]["value"], g);

  // A tighter table: the same measurement fails, judged by version 2.
  svc_->tolerances().Put("vmc-3axis", Body({GTol(g - 0.5, "xy-r150")}));
  const auto c = m.ListMeasurements({})["items"][0]["conformance"];
  EXPECT_EQ(c["verdict"], "fail");
  EXPECT_EQ(c["tolerance_version"], 2);
  EXPECT_EQ(m.Upload(ccw_file, "ccw.txt").conformance["verdict"], "fail");  // stored before
  EXPECT_EQ(m.Conformance(up.id)["verdict"], "fail");
  const auto cw = m.Upload(ExampleFile("dbb_xy-r150_cw.txt"), "cw.txt");
  EXPECT_EQ(cw.conformance["tolerance_version"], 2);
  EXPECT_EQ(cw.conformance["figures"][0]["tolerance"], g - 0.5);

  // The PDF prints the table's version, the figure with value, tolerance and verdict.
  const std::string text = PdfText(svc_->reports().MeasurementPdf(up.id));
  EXPECT_TRUE(test::Contains(text, "Conformance with the tolerances")) << text;
  EXPECT_TRUE(test::Contains(text, "tolerance table version 2")) << text;
  EXPECT_TRUE(test::Contains(text, "Circular deviation G")) << text;
  EXPECT_TRUE(test::Contains(text, "Verdict: fail")) << text;

  // A table of another set-up only: no tolerance applies.
  svc_->tolerances().Put("vmc-3axis", Body({GTol(1, "yz-*")}));
  EXPECT_EQ(m.Conformance(up.id)["verdict"], "no tolerance");
  EXPECT_EQ(m.Conformance(up.id)["tolerance_version"], 3);
  const std::string none = PdfText(svc_->reports().MeasurementPdf(up.id));
  EXPECT_TRUE(test::Contains(none, "No tolerance applies to this set-up")) << none;
}

}  // namespace
}  // namespace km::server
