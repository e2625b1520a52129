// Integration test: a real kinemetricd on a free port with a temporary data dir; upload, query,
// restart, and every kind of bad file — 400 with a precise problem document, nothing changed.
// Eigen before httplib: <resolv.h> (pulled in by httplib) defines the macro _res.
#include "analysis/sim/hexapod_dbb_sim.h"
#include "analysis/tracker/tracker_sim.h"
#include "ingest/dbb_writer.h"
#include "ingest/machine_json.h"
#include "ingest/tracker_parser.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <tuple>

#include "tests/integration/server/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char* kToken = "integration-secret-token";

std::string DbbFile(const std::string& test_id, bool ccw, double ellipse_um) {
  std::string s = "# format: kinemetric-dbb/1\n# machine_id: it-vmc\n# test_id: " + test_id +
                  "\n# direction: " + (ccw ? "ccw" : "cw") +
                  "\n# bar_length_mm: 150\n# centre_mm: 0, 0, 0\n# feed_mm_min: 1000\n"
                  "# timestamp: 2026-11-20T10:00:00+01:00\nangle_deg,dr_um\n";
  char buf[64];
  for (int i = 0; i < 720; ++i) {
    const double deg = (ccw ? 1 : -1) * 0.5 * i;
    const double th = deg * std::numbers::pi / 180;
    std::snprintf(buf, sizeof buf, "%.3f,%.5f\n", deg,
                  ellipse_um * std::cos(2 * th) + 2.0 * std::cos(th) - 1.0 * std::sin(th) + 0.5);
    s += buf;
  }
  return s;
}

class Api {
 public:
  explicit Api(int port) : c_("127.0.0.1", port) {
    c_.set_read_timeout(10, 0);
    c_.set_default_headers({{"Authorization", std::string("Bearer ") + kToken}});
  }
  httplib::Result Get(const std::string& p) { return c_.Get(p.c_str()); }
  httplib::Result Post(const std::string& body, const std::string& name = "f.dbb") {
    httplib::Headers h = {{"X-Filename", name}};
    return c_.Post("/api/v1/measurements", h, body, "text/plain");
  }

 private:
  httplib::Client c_;
};

class ServerIntegration : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("kinemetric-it-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::unique_ptr<km::test::ServerProcess> Start(const std::string& extra = "") {
    return std::make_unique<km::test::ServerProcess>(KINEMETRICD_BIN, dir_.string(), kToken, extra);
  }
  fs::path dir_;
};

std::int64_t Total(Api& api) {
  auto r = api.Get("/api/v1/measurements");
  EXPECT_TRUE(r);
  return json::parse(r->body)["total"].get<std::int64_t>();
}

TEST_F(ServerIntegration, UploadQueryRestartAndNothingLost) {
  auto server = Start();
  Api api(server->port());

  // Health needs no token; the API does.
  httplib::Client anon("127.0.0.1", server->port());
  EXPECT_EQ(anon.Get("/healthz")->status, 200);
  auto denied = anon.Get("/api/v1/machines");
  ASSERT_TRUE(denied);
  EXPECT_EQ(denied->status, 401);
  EXPECT_EQ(denied->get_header_value("Content-Type"), "application/problem+json");
  httplib::Client wrong("127.0.0.1", server->port());
  wrong.set_default_headers({{"Authorization", "Bearer nope"}});
  EXPECT_EQ(wrong.Get("/api/v1/machines")->status, 401);

  const std::string ccw = DbbFile("xy-150", true, 3.0), cw = DbbFile("xy-150", false, 3.0);
  auto r1 = api.Post(ccw, "ccw.dbb");
  ASSERT_TRUE(r1);
  ASSERT_EQ(r1->status, 201) << r1->body;
  const auto id1 = json::parse(r1->body)["id"].get<std::int64_t>();
  auto again = api.Post(ccw, "ccw-again.dbb");
  ASSERT_EQ(again->status, 200);
  EXPECT_EQ(json::parse(again->body)["id"].get<std::int64_t>(), id1);
  EXPECT_FALSE(json::parse(again->body)["created"].get<bool>());
  // curl --data-binary sends application/x-www-form-urlencoded: the body is still the file.
  {
    httplib::Client raw("127.0.0.1", server->port());
    raw.set_default_headers({{"Authorization", std::string("Bearer ") + kToken}});
    const std::string other = DbbFile("xy-form", true, 1.0);
    ASSERT_GT(other.size(), 8192u);
    auto r = raw.Post("/api/v1/measurements", other, "application/x-www-form-urlencoded");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 201) << r->body;
  }
  auto r2 = api.Post(cw, "cw.dbb");
  ASSERT_EQ(r2->status, 201);
  const auto id2 = json::parse(r2->body)["id"].get<std::int64_t>();

  // Results: the same object the CLI prints for the file, with the conformance to the machine's
  // tolerances beside it (none are set: "no tolerance").
  auto res = api.Get("/api/v1/measurements/" + std::to_string(id1) + "/results");
  ASSERT_EQ(res->status, 200) << res->body;
  json stored = json::parse(res->body);
  EXPECT_EQ(stored["conformance"]["verdict"], "no tolerance");
  stored.erase("conformance");
  // The file names no instrument: the service says so; the CLI (no register) leaves it out.
  EXPECT_TRUE(stored.contains("instrument") && stored["instrument"].is_null());
  stored.erase("instrument");
  EXPECT_EQ(stored["mode"], "centre_corrected");
  EXPECT_EQ(stored["direction"], "ccw");
  EXPECT_NEAR(stored["centre_offset_um"][0].get<double>(), 2.0, 1e-3);
  EXPECT_NEAR(stored["centre_offset_um"][1].get<double>(), -1.0, 1e-3);
  EXPECT_NEAR(stored["average_radial_error_um"].get<double>(), 0.5, 1e-3);
  EXPECT_NEAR(stored["circularity_um"].get<double>(), 6.0, 2e-3);
  {
    const fs::path f = dir_ / "cli-input.dbb";
    FILE* fp = std::fopen(f.c_str(), "w");
    std::fwrite(ccw.data(), 1, ccw.size(), fp);
    std::fclose(fp);
    const std::string cmd =
        std::string(KINEMETRIC_BIN) + " dbb analyze '" + f.string() + "' --json";
    FILE* p = popen(cmd.c_str(), "r");
    std::string out;
    char buf[4096];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
    ASSERT_EQ(pclose(p), 0);
    EXPECT_EQ(json::parse(out)["tests"][0], stored);
  }

  auto one = api.Get("/api/v1/measurements/" + std::to_string(id2));
  ASSERT_EQ(one->status, 200);
  const json m = json::parse(one->body);
  EXPECT_EQ(m["samples"]["angle_deg"].size(), 720u);
  EXPECT_EQ(m["metadata"]["test_id"], "xy-150");
  EXPECT_EQ(m["timestamp"], "2026-11-20T09:00:00Z");  // normalised to UTC

  auto trace = api.Get("/api/v1/measurements/" + std::to_string(id2) + "/trace");
  ASSERT_EQ(trace->status, 200);
  EXPECT_EQ(json::parse(trace->body)["radial_error_um"].size(), 720u);

  auto list = json::parse(api.Get("/api/v1/measurements?machine_id=it-vmc&kind=dbb&limit=1")->body);
  EXPECT_EQ(list["total"], 3);
  EXPECT_EQ(list["items"].size(), 1u);
  auto page2 = json::parse(
      api.Get("/api/v1/measurements?machine_id=it-vmc&test_id=xy-150&limit=1&offset=1")->body);
  EXPECT_EQ(page2["items"][0]["id"], id2);
  EXPECT_EQ(json::parse(api.Get("/api/v1/measurements?machine_id=other")->body)["total"], 0);
  EXPECT_EQ(json::parse(api.Get("/api/v1/measurements?from=2026-11-21")->body)["total"], 0);
  EXPECT_EQ(
      json::parse(api.Get("/api/v1/measurements?from=2026-11-20T08:59:00Z&to=2026-11-20T09:01:00Z")
                      ->body)["total"],
      3);
  EXPECT_EQ(api.Get("/api/v1/measurements?limit=0")->status, 400);
  EXPECT_EQ(api.Get("/api/v1/measurements?from=yesterday")->status, 400);
  // Newest first, the newest upload first, free text (an id with '#', URL-encoded), and an
  // order that does not exist (400 naming the field).
  auto newest = json::parse(
      api.Get("/api/v1/measurements?machine_id=it-vmc&kind=dbb&order=uploaded&limit=1")->body);
  EXPECT_EQ(newest["total"], 3);
  EXPECT_EQ(newest["items"][0]["id"], id2);  // the last upload
  EXPECT_TRUE(newest["items"][0]["key_result"]["value"].is_number());
  auto by_id =
      json::parse(api.Get("/api/v1/measurements?q=%23" + std::to_string(id2) + "&limit=5")->body);
  ASSERT_EQ(by_id["items"].size(), 1u);
  EXPECT_EQ(by_id["items"][0]["id"], id2);
  auto bad_order = api.Get("/api/v1/measurements?order=sideways");
  EXPECT_EQ(bad_order->status, 400);
  EXPECT_EQ(json::parse(bad_order->body)["field"], "order");
  EXPECT_EQ(api.Get("/api/v1/measurements/999")->status, 404);
  EXPECT_EQ(api.Get("/api/v1/measurements/abc")->status, 400);

  auto machines = json::parse(api.Get("/api/v1/machines")->body);
  ASSERT_EQ(machines["machines"].size(), 1u);
  EXPECT_EQ(machines["machines"][0]["measurement_count"], 3);

  // CW/CCW pair analysis and the polar plot.
  auto pair = api.Get("/api/v1/measurements/" + std::to_string(id1) + "/pair");
  ASSERT_EQ(pair->status, 200) << pair->body;
  const json pj = json::parse(pair->body);
  EXPECT_EQ(pj["partner_id"], id2);
  EXPECT_EQ(pj["pair"]["test_id"], "xy-150");
  EXPECT_GE(pj["pair"]["bidirectional_circular_deviation_um"].get<double>(),
            stored["circularity_um"].get<double>() - 1e-9);
  auto png = api.Get("/api/v1/measurements/" + std::to_string(id1) + "/plot.png");
  ASSERT_EQ(png->status, 200);
  EXPECT_EQ(png->get_header_value("Content-Type"), "image/png");
  EXPECT_EQ(png->body.substr(1, 3), "PNG");

  // The OpenAPI document lists every route.
  const json doc = json::parse(api.Get("/api/v1/openapi.json")->body);
  EXPECT_EQ(doc["openapi"], "3.0.3");
  for (const char* p : {"/api/v1/measurements", "/api/v1/measurements/{id}",
                        "/api/v1/measurements/{id}/results", "/api/v1/machines", "/healthz"}) {
    EXPECT_TRUE(doc["paths"].contains(p)) << p;
  }
  EXPECT_TRUE(doc["paths"]["/api/v1/measurements"].contains("post"));

  // Restart: everything is still there.
  EXPECT_EQ(server->Stop(), 0);
  server = Start();
  Api api2(server->port());
  EXPECT_EQ(Total(api2), 3);
  auto res2 = api2.Get("/api/v1/measurements/" + std::to_string(id1) + "/results");
  ASSERT_EQ(res2->status, 200);
  json restarted = json::parse(res2->body);
  restarted.erase("conformance");
  EXPECT_TRUE(restarted.contains("instrument"));
  restarted.erase("instrument");  // erased from `stored` above, to compare with the CLI
  EXPECT_EQ(restarted, stored);
  EXPECT_EQ(json::parse(api2.Post(cw)->body)["id"], id2);
}

TEST_F(ServerIntegration, BadFilesGetPreciseProblemsAndChangeNothing) {
  auto server = Start("--max-upload-bytes 200000");
  Api api(server->port());
  const std::string good = DbbFile("base", true, 1.0);
  ASSERT_EQ(api.Post(good)->status, 201);
  const auto before = api.Get("/api/v1/measurements")->body;

  auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  struct Case {
    const char* name;
    std::string body;
    int line;
    const char* field;
  };
  const Case cases[] = {
      {"missing key", replace("# test_id: base\n", ""), 0, "test_id"},
      {"unknown format", replace("kinemetric-dbb/1", "kinemetric-dbb/9"), 1, "format"},
      {"not numeric", replace("\n1.000,", "\n1.000,x"), 12, "dr_um"},
      {"nan", replace("\n1.000,", "\nnan,"), 12, "angle_deg"},
      {"inf", replace("\n1.000,", "\n1.000,-inf"), 12, "dr_um"},
      {"duplicated key",
       replace("# feed_mm_min: 1000\n", "# feed_mm_min: 1000\n# feed_mm_min: 900\n"), 8,
       "feed_mm_min"},
      {"too few samples", good.substr(0, good.find("\n90.000,")), 0, "angle_deg"},
      {"non-monotonic", replace("\n1.000,", "\n0.250,"), 12, "angle_deg"},
      {"empty", "", 0, "format"},
      {"binary", std::string("\x89PNG\r\n\x1a\n\0\0", 10), 0, ""},
  };
  for (const auto& c : cases) {
    auto r = api.Post(c.body, "bad.dbb");
    ASSERT_TRUE(r) << c.name;
    EXPECT_EQ(r->status, 400) << c.name << ": " << r->body;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/problem+json") << c.name;
    const json p = json::parse(r->body);
    EXPECT_EQ(p["status"], 400);
    EXPECT_FALSE(p["detail"].get<std::string>().empty());
    if (c.line) {
      EXPECT_EQ(p.value("line", 0), c.line) << c.name << ": " << p.dump();
    }
    if (*c.field) {
      EXPECT_EQ(p.value("field", ""), c.field) << c.name << ": " << p.dump();
    }
    EXPECT_EQ(p.value("file", ""), "bad.dbb") << c.name;
  }
  // Over the upload limit: 413 with a problem document.
  const std::string huge = good + std::string(250000, '\n');
  auto big = api.Post(huge);
  ASSERT_TRUE(big);
  EXPECT_EQ(big->status, 413);
  EXPECT_NE(json::parse(big->body)["detail"].get<std::string>().find("limit"), std::string::npos);
  EXPECT_EQ(api.Get("/api/v1/measurements")->body, before);
  EXPECT_EQ(api.Get("/api/v1/nothing")->status, 404);
}

}  // namespace

namespace {

std::string RunCli(const std::string& args) {
  FILE* p = popen((std::string(KINEMETRIC_BIN) + " " + args).c_str(), "r");
  std::string out;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  EXPECT_EQ(pclose(p), 0) << args;
  return out;
}

TEST_F(ServerIntegration, FormFilesAreStoredAndGiveTheCliResult) {
  auto server = Start();
  Api api(server->port());
  std::string straight =
      "# format: kinemetric-straightness/1\n# machine_id: it-form\n# axis: X\n"
      "# error_direction: Z\n# sensor: capacitance\n# reference: optical_flat\n"
      "position_mm,deviation_um\n";
  char buf[64];
  for (int i = 0; i <= 200; ++i) {
    const double x = 2.0 * i;
    std::snprintf(buf, sizeof buf, "%.3f,%.5f\n", x,
                  0.2 * std::sin(2 * std::numbers::pi * x / 55.0) + 0.001 * x);
    straight += buf;
  }
  std::string flat =
      "# format: kinemetric-flatness/1\n# machine_id: it-form\n# datum: table\nx_mm,y_mm,z_um\n";
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 10; ++j) {
      std::snprintf(buf, sizeof buf, "%d,%d,%.4f\n", 40 * i, 40 * j,
                    0.01 * i - 0.02 * j + 0.5 * std::cos(0.3 * i * j));
      flat += buf;
    }
  }
  for (const auto& [name, body, cmd] : {std::tuple{"s.txt", straight, "form straightness"},
                                        std::tuple{"f.txt", flat, "form flatness"}}) {
    auto r = api.Post(body, name);
    ASSERT_EQ(r->status, 201) << r->body;
    const auto id = json::parse(r->body)["id"].get<std::int64_t>();
    json stored =
        json::parse(api.Get("/api/v1/measurements/" + std::to_string(id) + "/results")->body);
    EXPECT_EQ(stored["conformance"]["verdict"], "no tolerance");
    stored.erase("conformance");  // the machine's tolerances judge it; the CLI knows none
    // The service names the instrument (with the register's values); the CLI has no register.
    EXPECT_TRUE(stored.contains("instrument"));
    stored.erase("instrument");
    const fs::path f = dir_ / name;
    FILE* fp = std::fopen(f.c_str(), "w");
    std::fwrite(body.data(), 1, body.size(), fp);
    std::fclose(fp);
    json cli = json::parse(RunCli(std::string(cmd) + " '" + f.string() + "' --json"));
    // The file name appears in the CLI output as given; the upload names it the same way.
    EXPECT_EQ(cli.value("flatness_min_zone_um", -1.0), stored.value("flatness_min_zone_um", -1.0));
    EXPECT_EQ(cli.value("straightness_min_zone_um", -1.0),
              stored.value("straightness_min_zone_um", -1.0));
    EXPECT_EQ(cli.size(), stored.size()) << cli.dump() << "\n" << stored.dump();
  }
  std::string bad = straight;
  bad.replace(bad.find("\n4.000,"), 7, "\n1.000,");
  auto r = api.Post(bad, "bad-straight.txt");
  EXPECT_EQ(r->status, 400);
  EXPECT_EQ(json::parse(r->body).value("field", ""), "position_mm") << r->body;
}

}  // namespace

namespace {

TEST_F(ServerIntegration, TrackerSurveyIsSelfCalibratedAtUpload) {
  auto server = Start();
  Api api(server->port());
  km::tracker::TrackerSimOptions o;
  const Eigen::Vector3d centre(0, 0, 200);
  o.commanded_mm = km::tracker::GridPoints(centre, 400.0, 4);
  o.trackers_mm = km::tracker::PlaceTrackers(centre, 4, 600.0, 1200.0, 3);
  o.machine.centre_mm = centre;
  o.machine.half_range_mm = Eigen::Vector3d::Constant(200.0);
  o.machine.squareness_um_per_m = Eigen::Vector3d(10.0, 0.0, 0.0);
  o.noise_um = 0.2;
  auto sim = km::tracker::SimulateTrackerSurvey(o);
  sim.readings.machine_id = "it-tracker";
  const std::string body = km::ingest::WriteTrackerFile(sim.readings);
  auto r = api.Post(body, "survey.txt");
  ASSERT_EQ(r->status, 201) << r->body;
  const auto id = json::parse(r->body)["id"].get<std::int64_t>();
  const json res =
      json::parse(api.Get("/api/v1/measurements/" + std::to_string(id) + "/results")->body);
  ASSERT_EQ(res["volumetric_error_um"].size(), o.commanded_mm.size());
  EXPECT_LT(res["residual_rms_um"].get<double>(), 1.0);
  const fs::path f = dir_ / "survey.txt";
  FILE* fp = std::fopen(f.c_str(), "w");
  std::fwrite(body.data(), 1, body.size(), fp);
  std::fclose(fp);
  const json cli = json::parse(RunCli("tracker selfcal '" + f.string() + "' --json"));
  // The same numbers to well below a nanometre: the least-squares solve goes through the
  // system's BLAS, whose summation order may differ between two processes (1e-10 µm seen).
  ASSERT_EQ(cli["volumetric_error_um"].size(), res["volumetric_error_um"].size());
  for (std::size_t i = 0; i < res["volumetric_error_um"].size(); ++i) {
    for (std::size_t k = 0; k < 3; ++k) {
      EXPECT_NEAR(cli["volumetric_error_um"][i][k].get<double>(),
                  res["volumetric_error_um"][i][k].get<double>(), 1e-6)
          << "point " << i << " axis " << k;
    }
  }

  // Three trackers cannot self-calibrate: refused with a clear problem, nothing stored.
  auto three = sim.readings;
  three.displacement_um.conservativeResize(Eigen::NoChange, 3);
  const std::string body3 = km::ingest::WriteTrackerFile(three);
  auto r3 = api.Post(body3, "three.txt");
  EXPECT_GE(r3->status, 400);
  EXPECT_LT(r3->status, 500);
  EXPECT_EQ(Total(api), 1);
}

}  // namespace

namespace {

TEST_F(ServerIntegration, HexapodCalibrationRunsAsABackgroundJob) {
  auto server = Start();
  Api api(server->port());
  const std::string machine_text =
      km::test::ReadFileText(KINEMETRIC_SOURCE_DIR "/tests/fixtures/pm600-like.json");
  ASSERT_FALSE(machine_text.empty());
  const auto machine = km::ingest::ParseHexapodMachineJson(machine_text, "pm600-like.json");
  const auto truth = km::sim::PerturbGeometry(machine.geometry, 0.3, 0.1, 11);
  km::sim::HexapodDbbSimOptions so;
  so.noise_um = 0.3;
  const auto tests = km::sim::SimulateHexapodDbbPlan(machine.geometry, truth,
                                                     km::sim::Table21Plan(180, false), so);
  json ids = json::array();
  for (const auto& t : tests) {
    auto r = api.Post(km::ingest::WriteDbb(t), t.test_id + ".dbb");
    ASSERT_EQ(r->status, 201) << r->body;
    ids.push_back(json::parse(r->body)["id"]);
  }
  httplib::Client c("127.0.0.1", server->port());
  c.set_default_headers({{"Authorization", std::string("Bearer ") + kToken}});
  const json req = {{"machine", json::parse(machine_text)}, {"measurement_ids", ids}};
  auto sub = c.Post("/api/v1/calibrations", req.dump(), "application/json");
  ASSERT_EQ(sub->status, 202) << sub->body;
  const auto job_id = json::parse(sub->body)["job_id"].get<std::int64_t>();
  json job;
  for (int i = 0; i < 600; ++i) {
    job = json::parse(api.Get("/api/v1/jobs/" + std::to_string(job_id))->body);
    if (job["status"] == "done" || job["status"] == "failed") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_EQ(job["status"], "done") << job.dump();
  const json& res = job["result"];
  EXPECT_EQ(res["method"], "absolute");
  EXPECT_EQ(res["tests"].size(), tests.size());
  // Recovered parameters: true − nominal within 5 µm.
  for (int j = 0; j < 6; ++j) {
    const double truth_um = (truth.strut_offset_mm[j] - machine.geometry.strut_offset_mm[j]) * 1000;
    EXPECT_NEAR(res["parameters"]["strut_offset_um"][j].get<double>(), truth_um, 5.0) << j;
  }
  EXPECT_TRUE(res.contains("calibrated_machine"));
  // [PM-600 report] table 2.2 shape: the jig calibration removes the centre deviation.
  double before = 0, after = 0;
  for (const auto& t : res["tests"]) {
    before += t["centre_deviation_before_um"].get<double>();
    after += t["centre_deviation_predicted_after_um"].get<double>();
  }
  EXPECT_LT(after, 0.2 * before);

  // A bad request is refused at once, with no job.
  auto bad = c.Post("/api/v1/calibrations", R"({"measurement_ids":[1]})", "application/json");
  EXPECT_EQ(bad->status, 400);
  auto missing =
      c.Post("/api/v1/calibrations",
             json({{"machine", json::parse(machine_text)}, {"measurement_ids", {9999}}}).dump(),
             "application/json");
  EXPECT_EQ(missing->status, 404);
  EXPECT_EQ(json::parse(api.Get("/api/v1/jobs")->body)["items"].size(), 1u);
}

}  // namespace
