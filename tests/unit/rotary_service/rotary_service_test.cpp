// Rotary R-test files through the service: an upload through the route table stores the object
// `kinemetric rotary analyze --json` prints and the poses as samples; a bad file is a 400 naming
// file, line and field; an audit rule on YOA_um judges each set-up by its own newest test (an
// error the poses do not determine is not evaluated); the PDF report reads in words.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "api/http.h"
#include "api/routes.h"
#include "ingest/rotary/rotary_parser.h"
#include "server/audits/audit_service.h"
#include "server/audits/fleet_service.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/rotary/rotary_sim.h"
#include "tests/unit/server/pdf_text.h"
#include "usecases/rotary/rotary_report.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string Read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string Example() {
  return Read(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/rotary_ac-trunnion.txt");
}

// The file with another test_id and every displacement `scale` times its value: the location
// errors scale with it (the model is linear in them to well within the noise).
std::string Scaled(const std::string& text, const std::string& test_id, double scale) {
  std::istringstream in(text);
  std::string line, out;
  bool rows = false;
  while (std::getline(in, line)) {
    if (line.rfind("# test_id:", 0) == 0) line = "# test_id: " + test_id;
    if (rows) {
      std::istringstream cells(line);
      std::string a, c, x, y, z, t;
      std::getline(cells, a, ',');
      std::getline(cells, c, ',');
      std::getline(cells, x, ',');
      std::getline(cells, y, ',');
      std::getline(cells, z, ',');
      std::getline(cells, t, ',');
      line = a + "," + c + "," + std::to_string(scale * std::stod(x)) + "," +
             std::to_string(scale * std::stod(y)) + "," + std::to_string(scale * std::stod(z)) +
             "," + t;
    }
    if (line.rfind("a_deg,", 0) == 0) rows = true;
    out += line + "\n";
  }
  return out;
}

class RotaryService : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("km-rotary-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    svc_ = std::make_unique<Service>(std::make_unique<SqliteStorage>((dir_ / "db").string()),
                                     ServiceOptions{});
    RegisterBuiltinKinds(svc_->measurements());
    api::AddRoutes(router_, *svc_);
    router_.SetHook(api::TokenHook(svc_->storage()));
    api::EnsureAdminToken(svc_->storage(), "boot");
  }
  void TearDown() override {
    svc_.reset();
    fs::remove_all(dir_);
  }
  api::Response Post(const std::string& body, const std::string& name) {
    api::Request req;
    req.method = "POST";
    req.path = "/api/v1/measurements";
    req.headers["authorization"] = "Bearer boot";
    req.headers["x-filename"] = name;
    req.body = body;
    return router_.Dispatch(req);
  }
  fs::path dir_;
  std::unique_ptr<Service> svc_;
  api::Router router_;
};

TEST_F(RotaryService, AnUploadStoresTheResultTheCommandPrintsAndThePoses) {
  const std::string bytes = Example();
  ASSERT_FALSE(bytes.empty());
  const auto r = Post(bytes, "rotary_ac-trunnion.txt");
  ASSERT_EQ(r.status, 201) << r.body;
  const json created = json::parse(r.body);
  EXPECT_EQ(created["kind"], "rotary");
  const auto id = created["id"].get<MeasurementId>();
  json stored = svc_->measurements().Results(id);
  const json cli = usecases::RotaryReportToJson(
      usecases::AnalyzeRotary(ingest::ParseRotaryFile(bytes, "rotary_ac-trunnion.txt")));
  stored.erase("instrument");  // the instrument the file names (docs/http.md "Instruments")
  EXPECT_EQ(stored, cli);
  // The simulator's truth (tests/sim/rotary_truth.py): YOA 13.7 µm, BOA −23.1 µrad.
  EXPECT_NEAR(stored["location_errors"]["YOA_um"]["value"].get<double>(), 13.7, 0.5);
  EXPECT_NEAR(stored["location_errors"]["BOA_urad"]["value"].get<double>(), -23.1, 2.0);
  EXPECT_EQ(stored["rank"], 8);
  const json list = svc_->measurements().ListMeasurements({});
  EXPECT_EQ(list["items"][0]["key_result"]["name"], "residual_rms_um");
  EXPECT_EQ(list["items"][0]["key_result"]["value"], stored["residual_rms_um"]);
  const json m = svc_->measurements().MeasurementWithSamples(id);
  EXPECT_EQ(m["test_id"], "rtest-ac");
  EXPECT_EQ(m["samples"]["dx_um"].size(), stored["poses"].get<std::size_t>());
  EXPECT_EQ(m["samples"]["c_deg"].size(), stored["poses"].get<std::size_t>());
}

TEST_F(RotaryService, ABadFileIsA400NamingFileLineAndField) {
  std::string bytes = Example();
  // The third pose (line 14) with a word for dy_um.
  const auto at = bytes.find("-90.000000,30.000000,");
  ASSERT_NE(at, std::string::npos);
  const auto line_end = bytes.find('\n', at);
  bytes.replace(at, line_end - at, "-90.000000,30.000000,4.41472,abc,2.27675,4.0");
  const auto r = Post(bytes, "bad.txt");
  ASSERT_EQ(r.status, 400) << r.body;
  const json problem = json::parse(r.body);
  EXPECT_EQ(problem["file"], "bad.txt") << r.body;
  EXPECT_EQ(problem["line"], 14) << r.body;
  EXPECT_EQ(problem["field"], "dy_um") << r.body;
  // A file whose first pose is not at zero angles names the line and the angle.
  std::string moved = Example();
  moved.replace(moved.find("0.000000,0.000000,0.00000"), 8, "5.000000");
  const auto r2 = Post(moved, "moved.txt");
  EXPECT_EQ(r2.status, 400) << r2.body;
  EXPECT_EQ(json::parse(r2.body)["line"], 12) << r2.body;
  EXPECT_EQ(svc_->storage().ListMeasurements({}).total, 0);
}

TEST_F(RotaryService, AnAuditOnYoaJudgesEachSetUpAndLeavesAnUndeterminedOneUnjudged) {
  const auto full = rotary::test::Simulate("AC", "full", 11);
  const auto tilt0 = rotary::test::Simulate("AC", "tilt0", 12);  // C turns at zero tilt only
  const std::string worse = Read(full.path);
  ASSERT_EQ(Post(worse, "worse.txt").status, 201);
  ASSERT_EQ(Post(Scaled(worse, "rtest-better", 0.4), "better.txt").status, 201);
  const auto t0 = Post(Read(tilt0.path), "tilt0.txt");
  ASSERT_EQ(t0.status, 201) << t0.body;
  const auto t0_result =
      svc_->measurements().Results(json::parse(t0.body)["id"].get<MeasurementId>());
  ASSERT_TRUE(t0_result["location_errors"]["YOA_um"]["value"].is_null()) << t0_result.dump();
  const json rules = {
      {"rules", {{{"kind", "rotary"}, {"metric", "YOA_um"}, {"warn", 10.0}, {"stop", 100.0}}}}};
  PutAuditConfig(*svc_, "sim-ac", rules, 1'772'400'000);
  const json verdict = RunAccuracyAudit(*svc_, "sim-ac", "manual", 1'772'400'000);
  EXPECT_EQ(verdict["level"], 2) << verdict.dump();
  ASSERT_EQ(verdict["findings"].size(), 1u) << verdict.dump();
  EXPECT_EQ(verdict["findings"][0]["metric"], "YOA_um");
  EXPECT_EQ(verdict["findings"][0]["test_id"], "AC-full-11") << verdict.dump();
  std::map<std::string, std::string> status;
  for (const auto& c : verdict["checked"]) status[c.value("test_id", "")] = c["status"];
  EXPECT_EQ(status["AC-full-11"], "finding") << verdict.dump();
  EXPECT_EQ(status["rtest-better"], "ok") << verdict.dump();
  EXPECT_EQ(status["AC-tilt0-12"], "not evaluated") << verdict.dump();
  // Tolerances read the same metric: the worse set-up fails, the better one passes.
  svc_->tolerances().Put(
      "sim-ac",
      {{"tolerances", {{{"kind", "rotary"}, {"metric", "YOA_um"}, {"tolerance", 10.0}}}}});
  std::map<std::string, std::string> conformance;
  const json list = svc_->measurements().ListMeasurements({});
  for (const auto& i : list["items"]) {
    conformance[i["test_id"].get<std::string>()] = i["conformance"].value("verdict", "");
  }
  EXPECT_EQ(conformance["AC-full-11"], "fail") << list.dump();
  EXPECT_EQ(conformance["rtest-better"], "pass");
  // The trend of a set-up holds its values; the undetermined one has none.
  const json trend = Trends(*svc_, "sim-ac", "YOA_um");
  EXPECT_EQ(trend["unit"], "µm");
  ASSERT_EQ(trend["points"].size(), 2u) << trend.dump();
  // A metric no result holds by that name is refused.
  EXPECT_FALSE(FindAuditMetric("rotary", "YOA"));
  EXPECT_TRUE(FindAuditMetric("rotary", "BOC_urad"));
}

TEST_F(RotaryService, ThePdfReportShowsTheLocationErrorsInWords) {
  const auto tilt0 = rotary::test::Simulate("AC", "tilt0", 13);
  const auto r = Post(Example(), "rotary_ac-trunnion.txt");
  ASSERT_EQ(r.status, 201) << r.body;
  const auto id = json::parse(r.body)["id"].get<MeasurementId>();
  const std::string text =
      km::test::PdfToText(svc_->reports().MeasurementPdf(id), (dir_ / "r.pdf").string());
  EXPECT_NE(text.find("Rotary axes: location errors (R-test, ISO 10791-6)"), std::string::npos)
      << text;
  EXPECT_NE(text.find("YOA, position error of the A axis line in Y"), std::string::npos) << text;
  EXPECT_NE(text.find("BOC, orientation error of the C axis line about Y"), std::string::npos);
  EXPECT_NE(text.find("µrad"), std::string::npos);
  EXPECT_NE(text.find("Rank of the pose set: 8 of 8"), std::string::npos) << text;
  EXPECT_NE(text.find("RMS of the residual (after the fit)"), std::string::npos);
  EXPECT_EQ(text.find("YOA_um"), std::string::npos) << text;
  EXPECT_EQ(text.find("residual_rms"), std::string::npos) << text;
  // A pose set that leaves errors undetermined says so in a sentence.
  const auto r2 = Post(Read(tilt0.path), "tilt0.txt");
  ASSERT_EQ(r2.status, 201) << r2.body;
  const std::string t2 = km::test::PdfToText(
      svc_->reports().MeasurementPdf(json::parse(r2.body)["id"].get<MeasurementId>()),
      (dir_ / "r2.pdf").string());
  EXPECT_NE(t2.find("not determined"), std::string::npos) << t2;
  EXPECT_NE(t2.find("What these poses do not determine"), std::string::npos) << t2;
  EXPECT_EQ(t2.find("_um"), std::string::npos) << t2;
}

}  // namespace
}  // namespace km::server
