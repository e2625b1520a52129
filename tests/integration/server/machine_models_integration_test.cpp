// Integration test: machine definitions over HTTP on a real kinemetricd with its own data dir:
// versions stored, listed and served (also after a restart), bad documents answered 400 naming
// the field, unknown machines and versions 404, a calibration from a stored model saved as the
// next version, discovery jobs on stored models.
#include "ingest/machine_json.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "tests/integration/server/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char* kModelToken = "machine-models-token";

std::string Fixture(const std::string& name) {
  return km::test::ReadFileText(std::string(KINEMETRIC_SOURCE_DIR) + "/tests/fixtures/" + name);
}

class MachineModelsHttp : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("kinemetric-models-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    Start();
  }
  void TearDown() override {
    client_.reset();
    server_.reset();
    fs::remove_all(dir_);
  }
  void Start() {
    client_.reset();
    server_.reset();
    server_ =
        std::make_unique<km::test::ServerProcess>(KINEMETRICD_BIN, dir_.string(), kModelToken);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    client_->set_read_timeout(30, 0);
    client_->set_default_headers({{"Authorization", std::string("Bearer ") + kModelToken}});
  }
  httplib::Result Get(const std::string& path) { return client_->Get(path.c_str()); }
  httplib::Result Post(const std::string& path, const std::string& body,
                       const std::string& type = "application/json") {
    return client_->Post(path.c_str(), body, type.c_str());
  }
  json PostJson(const std::string& path, const json& body, int status) {
    auto r = Post(path, body.dump());
    EXPECT_TRUE(r) << path;
    if (!r) return nullptr;
    EXPECT_EQ(r->status, status) << path << ": " << r->body;
    return json::parse(r->body);
  }
  // The ten hexapod DBB fixtures of the example machine, uploaded; their ids.
  json UploadHexapodTests() {
    json ids = json::array();
    for (char c = 'a'; c <= 'j'; ++c) {
      const std::string name = std::string("dbb_") + c + "_ccw.txt";
      httplib::Headers h = {{"X-Filename", name}};
      auto r = client_->Post("/api/v1/measurements", h, Fixture("browser/hexapod/" + name),
                             "text/plain");
      EXPECT_TRUE(r && r->status == 201) << name;
      if (r) ids.push_back(json::parse(r->body)["id"]);
    }
    return ids;
  }
  json WaitForJob(std::int64_t id) {
    json job;
    for (int i = 0; i < 1200; ++i) {
      job = json::parse(Get("/api/v1/jobs/" + std::to_string(id))->body);
      if (job["status"] == "done" || job["status"] == "failed") break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return job;
  }

  fs::path dir_;
  std::unique_ptr<km::test::ServerProcess> server_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(MachineModelsHttp, DefinitionsAreVersionedServedAndKeptAcrossARestart) {
  const std::string v1 = Fixture("pm600-like.json");
  json changed = json::parse(v1);
  changed["strut_offset_mm"] = {0.012, 0, 0, 0, -0.02, 0};
  const std::string v2 = changed.dump(2) + "\n";

  auto r1 = Post("/api/v1/machines?note=as%20delivered", v1);
  ASSERT_TRUE(r1);
  ASSERT_EQ(r1->status, 201) << r1->body;
  const json stored1 = json::parse(r1->body);
  EXPECT_EQ(stored1["machine_id"], "pm600-like");
  EXPECT_EQ(stored1["version"], 1);
  EXPECT_FALSE(stored1["created_at"].get<std::string>().empty());
  // The same bytes as the newest version: 200 with that version.
  auto same = Post("/api/v1/machines", v1);
  ASSERT_EQ(same->status, 200) << same->body;
  EXPECT_EQ(json::parse(same->body)["version"], 1);
  EXPECT_EQ(json::parse(same->body)["created_at"], stored1["created_at"]);
  auto r2 = Post("/api/v1/machines", v2);
  ASSERT_EQ(r2->status, 201) << r2->body;
  EXPECT_EQ(json::parse(r2->body)["version"], 2);
  // Back to the first document: a new version, nothing overwritten.
  ASSERT_EQ(json::parse(Post("/api/v1/machines", v1)->body)["version"], 3);

  // The newest document, exactly as stored; an older one with ?version=.
  auto newest = Get("/api/v1/machines/pm600-like/definition");
  ASSERT_EQ(newest->status, 200) << newest->body;
  EXPECT_EQ(newest->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(newest->get_header_value("X-Machine-Version"), "3");
  EXPECT_EQ(newest->body, v1);
  auto older = Get("/api/v1/machines/pm600-like/definition?version=2");
  ASSERT_EQ(older->status, 200);
  EXPECT_EQ(older->get_header_value("X-Machine-Version"), "2");
  EXPECT_EQ(older->body, v2);
  EXPECT_EQ(Get("/api/v1/machines/pm600-like/definition?version=1")->body, v1);

  const json list = json::parse(Get("/api/v1/machines/pm600-like/definitions")->body);
  EXPECT_EQ(list["machine_id"], "pm600-like");
  ASSERT_EQ(list["versions"].size(), 3u);
  EXPECT_EQ(list["versions"][0]["note"], "as delivered");
  EXPECT_EQ(list["versions"][0]["sha256"], list["versions"][2]["sha256"]);
  EXPECT_NE(list["versions"][0]["sha256"], list["versions"][1]["sha256"]);
  for (int i = 0; i < 3; ++i) {
    const json& v = list["versions"][static_cast<std::size_t>(i)];
    EXPECT_EQ(v["version"], i + 1);
    EXPECT_EQ(v["source"], "upload");
    EXPECT_EQ(v["sha256"].get<std::string>().size(), 64u);
    EXPECT_TRUE(v.contains("created_at"));
  }

  // Unknown machine or version: 404; a version that is not a whole number: 400.
  for (const char* path :
       {"/api/v1/machines/nobody/definition", "/api/v1/machines/nobody/definitions",
        "/api/v1/machines/pm600-like/definition?version=4"}) {
    auto r = Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 404) << path << ": " << r->body;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/problem+json") << path;
  }
  EXPECT_EQ(Get("/api/v1/machines/pm600-like/definition?version=two")->status, 400);
  EXPECT_EQ(Get("/api/v1/machines/pm600-like/definition?version=0")->status, 400);

  // The machine list includes a machine that has only a stored model.
  const json machines = json::parse(Get("/api/v1/machines")->body)["machines"];
  ASSERT_EQ(machines.size(), 1u);
  EXPECT_EQ(machines[0]["machine_id"], "pm600-like");
  EXPECT_EQ(machines[0]["measurement_count"], 0);
  EXPECT_EQ(machines[0]["model_versions"], 3);

  // Restart: every version is still there.
  server_->Stop();
  Start();
  EXPECT_EQ(Get("/api/v1/machines/pm600-like/definition?version=2")->body, v2);
  EXPECT_EQ(json::parse(Get("/api/v1/machines/pm600-like/definitions")->body), list);
}

TEST_F(MachineModelsHttp, BadDefinitionsAre400NamingTheFieldAndStoreNothing) {
  json no_base = json::parse(Fixture("pm600-like.json"));
  no_base.erase("base_joints_mm");
  json bad_offset = json::parse(Fixture("pm600-like.json"));
  bad_offset["strut_offset_mm"][4] = nullptr;
  json slash = json::parse(Fixture("pm600-like.json"));
  slash["machine_id"] = "hall/3";
  const struct {
    std::string body;
    std::string field;
  } cases[] = {
      {"{\"format\": ", ""},
      {"", ""},
      {no_base.dump(), "base_joints_mm"},
      {bad_offset.dump(), "strut_offset_mm[4]"},
      {slash.dump(), "machine_id"},
  };
  for (const auto& c : cases) {
    auto r = Post("/api/v1/machines", c.body);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 400) << c.body.substr(0, 40) << ": " << r->body;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/problem+json");
    const json p = json::parse(r->body);
    EXPECT_EQ(p.value("field", ""), c.field) << p.dump();
    EXPECT_FALSE(p["detail"].get<std::string>().empty());
  }
  // Beyond the route's body limit (1 MiB): 413 before the body is read.
  json huge = json::parse(Fixture("pm600-like.json"));
  huge["description"] = std::string(1100000, 'd');
  auto big = Post("/api/v1/machines", huge.dump());
  ASSERT_TRUE(big);
  EXPECT_EQ(big->status, 413) << big->body;
  EXPECT_TRUE(json::parse(Get("/api/v1/machines")->body)["machines"].empty());
}

TEST_F(MachineModelsHttp, ACalibrationFromAStoredMachineIsSavedAsVersionTwo) {
  const json ids = UploadHexapodTests();
  ASSERT_EQ(Post("/api/v1/machines", Fixture("pm600-like.json"))->status, 201);
  const json sub = PostJson("/api/v1/calibrations",
                            {{"machine_id", "pm600-like"}, {"measurement_ids", ids}}, 202);
  const auto job_id = sub["job_id"].get<std::int64_t>();
  const json job = WaitForJob(job_id);
  ASSERT_EQ(job["status"], "done") << job.dump();
  EXPECT_EQ(job["request"]["machine_version"], 1);

  const std::string save = "/api/v1/jobs/" + std::to_string(job_id) + "/save-machine";
  const json saved = PostJson(save, {{"note", "after calibration"}}, 201);
  EXPECT_EQ(saved["machine_id"], "pm600-like");
  EXPECT_EQ(saved["version"], 2);
  // Version 2's geometry is the calibrated one, number for number.
  auto doc = Get("/api/v1/machines/pm600-like/definition");
  ASSERT_EQ(doc->status, 200);
  const auto v2 = km::ingest::ParseHexapodMachineJson(doc->body, "v2");
  const auto cal =
      km::ingest::ParseHexapodMachineJson(job["result"]["calibrated_machine"].dump(), "result");
  for (int s = 0; s < 6; ++s) {
    EXPECT_EQ(v2.geometry.base_joints_mm[s], cal.geometry.base_joints_mm[s]) << s;
    EXPECT_EQ(v2.geometry.platform_joints_mm[s], cal.geometry.platform_joints_mm[s]) << s;
    EXPECT_EQ(v2.geometry.strut_offset_mm[s], cal.geometry.strut_offset_mm[s]) << s;
  }
  const json versions = json::parse(Get("/api/v1/machines/pm600-like/definitions")->body);
  EXPECT_EQ(versions["versions"][1]["source"], "calibration job " + std::to_string(job_id));
  EXPECT_EQ(versions["versions"][1]["note"], "after calibration");
  // Saving again (no body): the same bytes as the newest version, 200.
  auto again = Post(save, "");
  ASSERT_EQ(again->status, 200) << again->body;
  EXPECT_EQ(json::parse(again->body)["version"], 2);
  // The machine list counts the model versions next to the measurements.
  const json machines = json::parse(Get("/api/v1/machines")->body)["machines"];
  ASSERT_EQ(machines.size(), 1u);
  EXPECT_EQ(machines[0]["measurement_count"], 10);
  EXPECT_EQ(machines[0]["model_versions"], 2);

  // Refusals: an unknown job 404, an unknown stored machine 404, a bad version 400.
  EXPECT_EQ(Post("/api/v1/jobs/999/save-machine", "")->status, 404);
  EXPECT_EQ(Post(save, "[1]")->status, 400);
  EXPECT_EQ(Post("/api/v1/calibrations",
                 json({{"machine_id", "nobody"}, {"measurement_ids", ids}}).dump())
                ->status,
            404);
  EXPECT_EQ(
      Post("/api/v1/calibrations",
           json({{"machine_id", "pm600-like"}, {"machine_version", 7}, {"measurement_ids", ids}})
               .dump())
          ->status,
      404);
  auto bad =
      Post("/api/v1/calibrations",
           json({{"machine_id", "pm600-like"}, {"machine_version", "1"}, {"measurement_ids", ids}})
               .dump());
  EXPECT_EQ(bad->status, 400);
  EXPECT_EQ(json::parse(bad->body).value("field", ""), "machine_version");
}

TEST_F(MachineModelsHttp, DiscoveryJobsRunAndSaveTheUpdatedMachine) {
  // Serial discovery of the DBB tests' own machine: a result, and no machine to save (409).
  json pair = json::array();
  for (const char* name : {"dbb_xy-r150_ccw.txt", "dbb_xy-r150_cw.txt"}) {
    httplib::Headers h = {{"X-Filename", name}};
    auto r = client_->Post("/api/v1/measurements", h, Fixture(std::string("browser/") + name),
                           "text/plain");
    ASSERT_EQ(r->status, 201) << r->body;
    pair.push_back(json::parse(r->body)["id"]);
  }
  auto sub = Post("/api/v1/discoveries", json({{"measurement_ids", pair}}).dump());
  ASSERT_EQ(sub->status, 202) << sub->body;
  EXPECT_FALSE(sub->get_header_value("Location").empty());
  const auto serial_id = json::parse(sub->body)["job_id"].get<std::int64_t>();
  const json serial = WaitForJob(serial_id);
  ASSERT_EQ(serial["status"], "done") << serial.dump();
  EXPECT_EQ(serial["kind"], "discovery");
  EXPECT_TRUE(serial["result"].contains("verdict"));
  auto none = Post("/api/v1/jobs/" + std::to_string(serial_id) + "/save-machine", "");
  EXPECT_EQ(none->status, 409) << none->body;
  EXPECT_EQ(none->get_header_value("Content-Type"), "application/problem+json");

  // Hexapod discovery on the stored model: the updated machine becomes version 2.
  const json ids = UploadHexapodTests();
  ASSERT_EQ(Post("/api/v1/machines", Fixture("pm600-like.json"))->status, 201);
  const json hsub = PostJson("/api/v1/discoveries",
                             {{"machine_id", "pm600-like"}, {"measurement_ids", ids}}, 202);
  const auto hex_id = hsub["job_id"].get<std::int64_t>();
  const json hex = WaitForJob(hex_id);
  ASSERT_EQ(hex["status"], "done") << hex.dump();
  ASSERT_TRUE(hex["result"].contains("updated_machine"));
  const json saved =
      PostJson("/api/v1/jobs/" + std::to_string(hex_id) + "/save-machine", json::object(), 201);
  EXPECT_EQ(saved["version"], 2);
  EXPECT_EQ(json::parse(Get("/api/v1/machines/pm600-like/definition")->body),
            hex["result"]["updated_machine"]);
  EXPECT_EQ(
      json::parse(Get("/api/v1/machines/pm600-like/definitions")->body)["versions"][1]["source"],
      "discovery job " + std::to_string(hex_id));

  // Refused at once, with no job: tests of two machines, an unknown model, a repeated id.
  const auto jobs_before = json::parse(Get("/api/v1/jobs")->body)["items"].size();
  auto mixed = Post("/api/v1/discoveries", json({{"measurement_ids", {pair[0], ids[0]}}}).dump());
  EXPECT_EQ(mixed->status, 400);
  EXPECT_EQ(json::parse(mixed->body).value("field", ""), "measurement_ids");
  EXPECT_EQ(
      Post("/api/v1/discoveries", json({{"machine_id", "nobody"}, {"measurement_ids", ids}}).dump())
          ->status,
      404);
  EXPECT_EQ(
      Post("/api/v1/discoveries", json({{"measurement_ids", {pair[0], pair[0]}}}).dump())->status,
      400);
  EXPECT_EQ(Post("/api/v1/discoveries", "not json")->status, 400);
  EXPECT_EQ(json::parse(Get("/api/v1/jobs")->body)["items"].size(), jobs_before);
}

}  // namespace
