// Laser positioning files through the service: an upload stores the same result the command
// prints, the list shows its accuracy, and audits and trends read a positioning figure per axis.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "api/http.h"
#include "api/routes.h"
#include "ingest/positioning_parser.h"
#include "server/audits/audit_service.h"
#include "server/audits/fleet_service.h"
#include "server/demo/demo_data.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "usecases/positioning_export.h"
#include "usecases/positioning_report.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

std::string ExampleFile() {
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/positioning_x.txt");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The example as a test of another axis, a day later, with every reading `scale` times its
// deviation from the target (a worse axis).
std::string OtherAxis(const std::string& x, const std::string& axis, double scale) {
  std::istringstream in(x);
  std::string line, out;
  bool rows = false;
  while (std::getline(in, line)) {
    if (line == "# axis: X") line = "# axis: " + axis;
    if (line.rfind("# timestamp:", 0) == 0) line = "# timestamp: 2026-11-21T09:30:00Z";
    if (rows) {
      std::istringstream cells(line);
      std::string run, dir, target, measured;
      std::getline(cells, run, ',');
      std::getline(cells, dir, ',');
      std::getline(cells, target, ',');
      std::getline(cells, measured, ',');
      const double t = std::stod(target);
      line = run + "," + dir + "," + target + "," +
             std::to_string(t + scale * (std::stod(measured) - t));
    }
    if (line.rfind("run,", 0) == 0) rows = true;
    out += line + "\n";
  }
  return out;
}

class PositioningService : public ::testing::Test {
 protected:
  void SetUp() override {
    db_ = fs::temp_directory_path() / ("km-positioning-" + std::to_string(::getpid()) + ".db");
    fs::remove(db_);
    svc_ =
        std::make_unique<Service>(std::make_unique<SqliteStorage>(db_.string()), ServiceOptions{});
    RegisterBuiltinKinds(svc_->measurements());
  }
  void TearDown() override {
    svc_.reset();
    fs::remove(db_);
  }
  fs::path db_;
  std::unique_ptr<Service> svc_;
};

TEST_F(PositioningService, AnUploadStoresTheResultTheCommandPrints) {
  const std::string bytes = ExampleFile();
  ASSERT_FALSE(bytes.empty());
  const auto out = svc_->measurements().Upload(bytes, "positioning_x.txt");
  EXPECT_TRUE(out.created);
  EXPECT_EQ(out.kind, "positioning");
  const auto stored = svc_->measurements().Results(out.id);
  const auto cli = usecases::PositioningReportToJson(
      usecases::AnalyzePositioning(ingest::ParsePositioningFile(bytes, "positioning_x.txt")));
  // The service adds the instrument the file names (docs/http.md "Instruments"); the rest is
  // the command's object.
  EXPECT_EQ(stored["instrument"]["instrument"], "laser interferometer, linear optics");
  nlohmann::json figures = stored;
  figures.erase("instrument");
  EXPECT_EQ(figures, cli);
  EXPECT_GT(stored["accuracy_um"].get<double>(), 5.0);  // a visible pitch error
  const auto list = svc_->measurements().ListMeasurements({});
  ASSERT_EQ(list["items"].size(), 1u);
  EXPECT_EQ(list["items"][0]["test_id"], "X");
  EXPECT_EQ(list["items"][0]["key_result"]["name"], "accuracy_um");
  EXPECT_EQ(list["items"][0]["key_result"]["value"], stored["accuracy_um"]);
  // The corrected readings are kept as samples, one row per reading.
  const auto m = svc_->measurements().MeasurementWithSamples(out.id);
  EXPECT_EQ(m["samples"]["deviation_um"].size(), stored["readings"].get<std::size_t>());
}

TEST_F(PositioningService, AnAuditJudgesEachAxisByItsOwnNewestTest) {
  const std::string x = ExampleFile();
  const auto ix = svc_->measurements().Upload(x, "x.txt");
  const auto iy = svc_->measurements().Upload(OtherAxis(x, "Y", 3.0), "y.txt");
  const double ax = svc_->measurements().Results(ix.id)["accuracy_um"].get<double>();
  const double ay = svc_->measurements().Results(iy.id)["accuracy_um"].get<double>();
  ASSERT_GT(ay, 2.0 * ax);  // Y is the worse axis
  // X passes its own limit although the newest test of the machine (Y) would not.
  const nlohmann::json rules = {
      {"rules",
       {{{"kind", "positioning"}, {"metric", "accuracy_um.X"}, {"warn", ax + 1.0}},
        {{"kind", "positioning"},
         {"metric", "accuracy_um.Y"},
         {"warn", ax + 1.0},
         {"stop", 1e4}}}}};
  PutAuditConfig(*svc_, "vmc-3axis", rules, 1'800'000'000);
  const auto verdict = RunAccuracyAudit(*svc_, "vmc-3axis", "manual", 1'800'000'000);
  EXPECT_EQ(verdict["level"], 2);
  ASSERT_EQ(verdict["findings"].size(), 1u) << verdict.dump();
  EXPECT_EQ(verdict["findings"][0]["metric"], "accuracy_um.Y");
  EXPECT_EQ(verdict["findings"][0]["measurement_id"], nlohmann::json(iy.id));
  // A trend of one axis holds that axis's tests only.
  const auto trend = Trends(*svc_, "vmc-3axis", "accuracy_um.X");
  ASSERT_EQ(trend["points"].size(), 1u);
  EXPECT_DOUBLE_EQ(trend["points"][0]["value"].get<double>(), ax);
  EXPECT_EQ(Trends(*svc_, "vmc-3axis", "accuracy_um")["points"].size(), 2u);
  // An axis name that is not one is no metric.
  EXPECT_THROW(Trends(*svc_, "vmc-3axis", "accuracy_um.x!"), InvalidInput);
}

TEST_F(PositioningService, TheApiGivesTheCompensationTableOfTheCommand) {
  const std::string bytes = ExampleFile();
  const auto out = svc_->measurements().Upload(bytes, "positioning_x.txt");
  api::Router router;
  api::AddRoutes(router, *svc_);
  router.SetHook(api::TokenHook(svc_->storage()));
  api::EnsureAdminToken(svc_->storage(), "boot");
  const auto get = [&](const std::string& query) {
    api::Request req;
    req.method = "GET";
    req.path = "/api/v1/measurements/" + to_string(out.id) + "/compensation";
    req.query.emplace("format", query);
    req.headers["authorization"] = "Bearer boot";
    return router.Dispatch(req);
  };
  const auto report =
      usecases::AnalyzePositioning(ingest::ParsePositioningFile(bytes, "positioning_x.txt"));
  const auto linuxcnc = get("linuxcnc");
  ASSERT_EQ(linuxcnc.status, 200) << linuxcnc.body;
  EXPECT_EQ(linuxcnc.body, usecases::ExportLinuxCnc(report));
  // One line a target; each trim is minus the mean deviation of its direction, in mm.
  std::istringstream lines(linuxcnc.body);
  std::string line;
  std::size_t i = 0;
  const auto& t = report.figures.targets;
  while (std::getline(lines, line)) {
    ASSERT_LT(i, t.size());
    std::istringstream cells(line);
    double nominal = 0, forward = 0, reverse = 0;
    cells >> nominal >> forward >> reverse;
    EXPECT_NEAR(nominal, t[i].target_mm, 1e-6);
    EXPECT_NEAR(forward, -t[i].mean_up_um / 1000.0, 1e-6);
    EXPECT_NEAR(reverse, -t[i].mean_down_um / 1000.0, 1e-6);
    ++i;
  }
  EXPECT_EQ(i, t.size());
  EXPECT_EQ(get("sinumerik").body, usecases::ExportSinumerik(report));
  EXPECT_EQ(get("csv").content_type, "text/csv");
  const auto bad = get("fanuc");
  EXPECT_EQ(bad.status, 400);
  EXPECT_NE(bad.body.find("format"), std::string::npos);
}

// The demo test of a fresh server: a 12 µm/m pitch error on a machine at 21 °C (11.5 ppm/K) and
// 3 µm reversal. Referred to 20 °C, the slope of the mean deviations is the pitch error alone
// (the warm scale would add 11.5 µm/m; a correction of the wrong sign 23 µm/m).
TEST_F(PositioningService, TheDemoTestShowsItsPitchErrorReferredTo20C) {
  const auto demo = DemoPositioningFile();
  const auto out = svc_->measurements().Upload(demo.bytes, demo.name);
  const auto r = svc_->measurements().Results(out.id);
  EXPECT_TRUE(r["iso230_2_compliant"].get<bool>());
  EXPECT_NEAR(r["mean_reversal_value_um"].get<double>(), 3.0, 0.3);
  const auto& x = r["targets"]["target_mm"];
  const auto& m = r["targets"]["mean_bidirectional_um"];
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double xi = x[i].get<double>(), yi = m[i].get<double>();
    sx += xi;
    sy += yi;
    sxx += xi * xi;
    sxy += xi * yi;
  }
  const double slope_um_per_m = 1000.0 * (n * sxy - sx * sy) / (n * sxx - sx * sx);
  EXPECT_NEAR(slope_um_per_m, 12.0, 1.5);
  EXPECT_TRUE(r["material"]["applied"].get<bool>());
  EXPECT_NEAR(r["material"]["correction_at_end_um"].get<double>(), -5.75, 1e-9);
}

}  // namespace
}  // namespace km::server
