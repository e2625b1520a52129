// Machine definitions kept by the server, versioned, on a real SQLite file: versions are
// appended and never overwritten, the same bytes again give the newest version back, older
// versions stay readable, bad documents are refused naming the field; calibration and discovery
// studies take a stored model, and the machine a finished job produced is saved as the next
// version.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include "analysis/core/errors.h"
#include "ingest/machine_json.h"
#include "server/base/errors.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/expect_error.h"
#include "tests/unit/server/study_request_json.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server {
namespace {

using km::test::Contains;
using km::test::Expect;
using nlohmann::json;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string Pm600() {
  return ReadFile("tests/fixtures/pm600-like.json");
}

// The example machine with one key changed (a new document of the same machine).
std::string Pm600With(const std::string& key, const json& value) {
  json doc = json::parse(Pm600());
  doc[key] = value;
  return doc.dump(2) + "\n";
}

NewMachineModel Model(const std::string& machine, const std::string& document) {
  NewMachineModel m;
  m.machine_id = machine;
  m.source = "upload";
  m.note = "note of " + document;
  m.document = document;
  m.sha256 = "sha-" + document;
  return m;
}

JobRecord Job(JobId id, JobStatus status, double progress, const std::string& stage,
              const std::string& result, const std::string& error) {
  JobRecord j;
  j.id = id;
  j.status = status;
  j.progress = progress;
  j.stage = stage;
  j.result_json = result;
  j.error = error;
  return j;
}

class MachineModels : public test::TempDirTest {
 protected:
  // job_workers 0: the jobs stay as stored (an instance that runs none).
  void Start(int job_workers = 1) {
    ServiceOptions options;
    options.jobs.workers = job_workers;
    service_ = std::make_unique<Service>(std::make_unique<SqliteStorage>(Path("km.db")), options);
    RegisterBuiltinKinds(service_->measurements());
  }
  void TearDown() override {
    service_.reset();
    test::TempDirTest::TearDown();
  }
  // The ten hexapod DBB fixtures of the example machine (tool length and fixed ball), uploaded.
  json UploadHexapodTests() {
    json ids = json::array();
    for (char c = 'a'; c <= 'j'; ++c) {
      const std::string name = std::string("dbb_") + c + "_ccw.txt";
      ids.push_back(service_->measurements()
                        .Upload(ReadFile("tests/fixtures/browser/hexapod/" + name), name)
                        .id);
    }
    return ids;
  }
  json WaitForJob(JobId id) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::minutes(5);
    while (std::chrono::steady_clock::now() < until) {
      const auto j = service_->studies().Job(id);
      if (j["status"] == "done" || j["status"] == "failed") return j;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "job " << id << " did not finish";
    return service_->studies().Job(id);
  }

  std::unique_ptr<Service> service_;
};

TEST_F(MachineModels, StorageAppendsVersionsAndNeverOverwritesThem) {
  {
    SqliteStorage s(Path("km.db"));
    const auto v1 = s.PutMachineModel(Model("hx", "doc one"));
    EXPECT_TRUE(v1.created);
    EXPECT_EQ(v1.record.version, 1);
    EXPECT_FALSE(v1.record.created_at.empty());
    const auto v2 = s.PutMachineModel(Model("hx", "doc two"));
    EXPECT_TRUE(v2.created);
    EXPECT_EQ(v2.record.version, 2);
    // The bytes of the newest version again: that version, nothing written.
    auto same = Model("hx", "doc two");
    same.source = "calibration job 9";
    const auto again = s.PutMachineModel(same);
    EXPECT_FALSE(again.created);
    EXPECT_EQ(again.record.version, 2);
    EXPECT_EQ(again.record.source, "upload");
    // The bytes of an older version: a new version (the model went back to them).
    const auto back = s.PutMachineModel(Model("hx", "doc one"));
    EXPECT_TRUE(back.created);
    EXPECT_EQ(back.record.version, 3);
    // Versions count per machine.
    EXPECT_EQ(s.PutMachineModel(Model("other", "doc one")).record.version, 1);
  }
  SqliteStorage s(Path("km.db"));  // reopened: everything kept
  const auto newest = s.GetMachineModel("hx", std::nullopt);
  ASSERT_TRUE(newest);
  EXPECT_EQ(newest->version, 3);
  EXPECT_EQ(newest->document, "doc one");
  const auto v2 = s.GetMachineModel("hx", 2);
  ASSERT_TRUE(v2);
  EXPECT_EQ(v2->document, "doc two");
  EXPECT_EQ(v2->note, "note of doc two");
  EXPECT_EQ(v2->sha256, "sha-doc two");
  EXPECT_FALSE(s.GetMachineModel("hx", 4));
  EXPECT_FALSE(s.GetMachineModel("nobody", std::nullopt));
  const auto list = s.ListMachineModels("hx");
  ASSERT_EQ(list.size(), 3u);
  for (std::size_t i = 0; i < list.size(); ++i) {
    EXPECT_EQ(list[i].version, static_cast<std::int64_t>(i + 1));
    EXPECT_TRUE(list[i].document.empty());  // lists carry no documents
  }
  EXPECT_TRUE(s.ListMachineModels("nobody").empty());
}

TEST_F(MachineModels, StoredVersionsAreImmutableInTheDatabaseItself) {
  { SqliteStorage(Path("km.db")).PutMachineModel(Model("hx", "doc")); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(Path("km.db").c_str(), &db), SQLITE_OK);
  EXPECT_NE(sqlite3_exec(db, "UPDATE machine_models SET document = 'x'", nullptr, nullptr, nullptr),
            SQLITE_OK);
  EXPECT_NE(sqlite3_exec(db, "DELETE FROM machine_models", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  EXPECT_EQ(SqliteStorage(Path("km.db")).GetMachineModel("hx", 1)->document, "doc");
}

TEST_F(MachineModels, MachinesWithOnlyAStoredModelAreListed) {
  Start();
  service_->measurements().Upload(ReadFile("tests/fixtures/browser/dbb_xy-r150_ccw.txt"),
                                  "ccw.txt");
  service_->models().StoreMachineModel(Pm600(), "upload", "");
  service_->models().StoreMachineModel(Pm600With("description", "second"), "upload", "");
  const auto machines = service_->storage().ListMachines();
  ASSERT_EQ(machines.size(), 2u);
  EXPECT_EQ(machines[0].machine_id, "browser-test-vmc");
  EXPECT_EQ(machines[0].measurement_count, 1);
  EXPECT_TRUE(machines[0].last_time);
  EXPECT_EQ(machines[0].model_versions, 0);
  EXPECT_EQ(machines[1].machine_id, "pm600-like");
  EXPECT_EQ(machines[1].measurement_count, 0);
  EXPECT_FALSE(machines[1].last_time);
  EXPECT_EQ(machines[1].model_versions, 2);
}

TEST_F(MachineModels, TheServiceKeepsTheBytesAndAnswersOlderVersions) {
  Start();
  const std::string first = Pm600();
  const auto v1 = service_->models().StoreMachineModel(first, "upload", "as delivered");
  EXPECT_TRUE(v1.created);
  EXPECT_EQ(v1.machine_id, "pm600-like");
  EXPECT_EQ(v1.version, 1);
  const auto same = service_->models().StoreMachineModel(first, "upload", "again");
  EXPECT_FALSE(same.created);
  EXPECT_EQ(same.version, 1);
  EXPECT_EQ(same.created_at, v1.created_at);
  const std::string second = Pm600With("strut_offset_mm", {0.01, 0, 0, 0, 0, -0.02});
  EXPECT_EQ(service_->models().StoreMachineModel(second, "upload", "").version, 2);

  EXPECT_EQ(service_->models().GetMachineModel("pm600-like").document, second);
  EXPECT_EQ(service_->models().GetMachineModel("pm600-like", 1).document, first);  // byte for byte
  const auto list = service_->models().ListMachineModels("pm600-like");
  EXPECT_EQ(list["machine_id"], "pm600-like");
  ASSERT_EQ(list["versions"].size(), 2u);
  EXPECT_EQ(list["versions"][0]["note"], "as delivered");
  EXPECT_EQ(list["versions"][0]["source"], "upload");
  EXPECT_EQ(list["versions"][1]["version"], 2);
  EXPECT_EQ(list["versions"][1]["sha256"].get<std::string>().size(), 64u);

  const auto none = Expect<NotFound>([&] { service_->models().GetMachineModel("nobody"); });
  EXPECT_TRUE(Contains(none.what(), "'nobody'")) << none.what();
  const auto v9 = Expect<NotFound>([&] { service_->models().GetMachineModel("pm600-like", 9); });
  EXPECT_TRUE(Contains(v9.what(), "version 9")) << v9.what();
  EXPECT_TRUE(Contains(v9.what(), "newest is version 2")) << v9.what();
  EXPECT_THROW(service_->models().ListMachineModels("nobody"), NotFound);
}

TEST_F(MachineModels, BadDocumentsAreRefusedNamingTheFieldAndNothingIsStored) {
  Start();
  json no_platform = json::parse(Pm600());
  no_platform.erase("platform_joints_mm");
  json bad_joint = json::parse(Pm600());
  bad_joint["base_joints_mm"][2][1] = "far";
  const struct {
    std::string body;
    std::string field;
  } cases[] = {
      {"{not json", ""},
      {"[1, 2]", ""},
      {no_platform.dump(), "platform_joints_mm"},
      {bad_joint.dump(), "base_joints_mm[2][1]"},
      {Pm600With("format", "kinemetric-machine/9"), "format"},
      {Pm600With("kind", "robot"), "kind"},
      {Pm600With("machine_id", ""), "machine_id"},
      {Pm600With("machine_id", "a/b"), "machine_id"},
      {Pm600With("machine_id", ".."), "machine_id"},
      {Pm600With("machine_id", "tab\there"), "machine_id"},
      {Pm600With("machine_id", std::string(300, 'm')), "machine_id"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.body.substr(0, 60));
    const auto e = Expect<InvalidInput>(
        [&] { service_->models().StoreMachineModel(c.body, "upload", "", "m.json"); });
    EXPECT_EQ(e.field(), c.field) << e.what();
    EXPECT_EQ(e.file(), "m.json");
  }
  const auto note = Expect<InvalidInput>(
      [&] { service_->models().StoreMachineModel(Pm600(), "upload", std::string(5000, 'n')); });
  EXPECT_EQ(note.field(), "note");
  const std::string huge = Pm600With("description", std::string(kMaxMachineModelBytes, 'd'));
  EXPECT_THROW(service_->models().StoreMachineModel(huge, "upload", ""), TooLarge);
  EXPECT_TRUE(service_->storage().ListMachines().empty());
}

TEST_F(MachineModels, ACalibrationFromAStoredModelIsSavedAsItsNextVersion) {
  Start();
  const json ids = UploadHexapodTests();
  service_->models().StoreMachineModel(Pm600(), "upload", "nominal");
  const auto job = km::test::SubmitCalibrationJson(
      *service_, {{"machine_id", "pm600-like"}, {"measurement_ids", ids}});
  const json j = WaitForJob(job);
  ASSERT_EQ(j["status"], "done") << j.dump();
  EXPECT_EQ(j["request"]["machine_id"], "pm600-like");
  EXPECT_EQ(j["request"]["machine_version"], 1);  // the version used is recorded

  const auto saved = service_->studies().SaveJobMachine(job, "after the jig calibration");
  EXPECT_TRUE(saved.created);
  EXPECT_EQ(saved.machine_id, "pm600-like");
  EXPECT_EQ(saved.version, 2);
  // Version 2 holds the calibrated geometry of the job, number for number.
  const auto stored = ingest::ParseHexapodMachineJson(
      service_->models().GetMachineModel("pm600-like", 2).document, "v2");
  const auto calibrated =
      ingest::ParseHexapodMachineJson(j["result"]["calibrated_machine"].dump(), "result");
  const auto nominal = ingest::ParseHexapodMachineJson(Pm600(), "v1");
  for (int s = 0; s < 6; ++s) {
    EXPECT_EQ(stored.geometry.base_joints_mm[s], calibrated.geometry.base_joints_mm[s]) << s;
    EXPECT_EQ(stored.geometry.platform_joints_mm[s], calibrated.geometry.platform_joints_mm[s])
        << s;
    EXPECT_EQ(stored.geometry.strut_offset_mm[s], calibrated.geometry.strut_offset_mm[s]) << s;
  }
  EXPECT_NE(stored.geometry.strut_offset_mm, nominal.geometry.strut_offset_mm);
  // The stored version is the text the job's machine writer produced, byte for byte.
  const std::string written = service_->storage().GetJob(job)->machine_document;
  ASSERT_FALSE(written.empty());
  EXPECT_EQ(service_->models().GetMachineModel("pm600-like", 2).document, written);
  EXPECT_EQ(ingest::WriteMachineJson(stored), written);
  const auto versions = service_->models().ListMachineModels("pm600-like")["versions"];
  EXPECT_EQ(versions[1]["source"], "calibration job " + to_string(job));
  EXPECT_EQ(versions[1]["note"], "after the jig calibration");
  // Saving it again: the same bytes as the newest version, nothing new.
  const auto again = service_->studies().SaveJobMachine(job, "");
  EXPECT_FALSE(again.created);
  EXPECT_EQ(again.version, 2);

  // An older version is named explicitly; the newest is the default.
  const auto older = km::test::SubmitCalibrationJson(
      *service_, {{"machine_id", "pm600-like"}, {"machine_version", 1}, {"measurement_ids", ids}});
  EXPECT_EQ(service_->studies().Job(older)["request"]["machine_version"], 1);
  const auto newest = km::test::SubmitCalibrationJson(
      *service_, {{"machine_id", "pm600-like"}, {"measurement_ids", ids}});
  EXPECT_EQ(service_->studies().Job(newest)["request"]["machine_version"], 2);
  WaitForJob(older);
  WaitForJob(newest);
}

TEST_F(MachineModels, CalibrationRequestsNamingAStoredModelAreChecked) {
  Start();
  const json ids = UploadHexapodTests();
  service_->models().StoreMachineModel(Pm600(), "upload", "");
  json serial = json::parse(Pm600());
  serial["machine_id"] = "vmc";
  serial["kind"] = "serial";
  service_->models().StoreMachineModel(serial.dump(), "upload", "");

  EXPECT_THROW(km::test::SubmitCalibrationJson(
                   *service_, {{"machine_id", "nobody"}, {"measurement_ids", ids}}),
               NotFound);
  EXPECT_THROW(km::test::SubmitCalibrationJson(*service_, {{"machine_id", "pm600-like"},
                                                           {"machine_version", 2},
                                                           {"measurement_ids", ids}}),
               NotFound);
  const auto field = [&](const json& request) {
    return Expect<InvalidInput>([&] { km::test::SubmitCalibrationJson(*service_, request); })
        .field();
  };
  EXPECT_EQ(field({{"machine_id", "pm600-like"}, {"machine_version", 0}, {"measurement_ids", ids}}),
            "machine_version");
  EXPECT_EQ(field({{"machine_id", 7}, {"measurement_ids", ids}}), "machine_id");
  EXPECT_EQ(field({{"machine_id", "vmc"}, {"measurement_ids", ids}}), "machine_id");  // serial
  EXPECT_EQ(field({{"machine", json::parse(Pm600())},
                   {"machine_id", "pm600-like"},
                   {"measurement_ids", ids}}),
            "machine_id");
  EXPECT_EQ(field({{"measurement_ids", ids}}), "machine");
  EXPECT_TRUE(service_->storage().ListJobs(10).empty());
}

TEST_F(MachineModels, SavingTheMachineOfAJobWithoutOneIsAConflict) {
  Start(0);
  EXPECT_THROW(service_->studies().SaveJobMachine(JobId(42), ""), NotFound);
  auto& st = service_->storage();
  // Job records in each state (not run: the records alone decide).
  const auto queued = st.CreateJob("hexapod_calibration", "{}");
  const auto c1 = Expect<Conflict>([&] { service_->studies().SaveJobMachine(queued, ""); });
  EXPECT_TRUE(Contains(c1.what(), "is queued")) << c1.what();
  const auto failed = st.CreateJob("hexapod_calibration", "{}");
  st.UpdateJob(Job(failed, JobStatus::kFailed, 0.0, "", "", "no convergence"));
  const auto c2 = Expect<Conflict>([&] { service_->studies().SaveJobMachine(failed, ""); });
  EXPECT_TRUE(Contains(c2.what(), "is failed")) << c2.what();
  const auto serial = st.CreateJob("discovery", "{}");
  st.UpdateJob(Job(serial, JobStatus::kDone, 1.0, "done", R"({"verdict":"ok"})", ""));
  const auto c3 = Expect<Conflict>([&] { service_->studies().SaveJobMachine(serial, ""); });
  EXPECT_TRUE(Contains(c3.what(), "updated_machine")) << c3.what();
  const auto other = st.CreateJob("something_else", "{}");
  st.UpdateJob(Job(other, JobStatus::kDone, 1.0, "done", "{}", ""));
  EXPECT_THROW(service_->studies().SaveJobMachine(other, ""), Conflict);
  EXPECT_TRUE(st.ListMachines().empty());
  // A job finished before its machine document was kept: the machine of its result is saved.
  const auto older = st.CreateJob("hexapod_calibration", "{}");
  st.UpdateJob(Job(older, JobStatus::kDone, 1.0, "done",
                   json{{"calibrated_machine", json::parse(Pm600())}}.dump(), ""));
  const auto saved = service_->studies().SaveJobMachine(older, "");
  EXPECT_EQ(json::parse(service_->models().GetMachineModel(saved.machine_id).document),
            json::parse(Pm600()));
}

TEST_F(MachineModels, DiscoveryJobsRunOnStoredModelsAndSaveTheUpdatedMachine) {
  Start();
  // Serial: the DBB tests' own machine, no model; nothing to save.
  const auto ccw = service_->measurements()
                       .Upload(ReadFile("tests/fixtures/browser/dbb_xy-r150_ccw.txt"), "ccw.txt")
                       .id;
  const auto cw = service_->measurements()
                      .Upload(ReadFile("tests/fixtures/browser/dbb_xy-r150_cw.txt"), "cw.txt")
                      .id;
  const auto serial = km::test::SubmitDiscoveryJson(*service_, {{"measurement_ids", {ccw, cw}}});
  const json sj = WaitForJob(serial);
  ASSERT_EQ(sj["status"], "done") << sj.dump();
  EXPECT_EQ(sj["kind"], "discovery");
  EXPECT_EQ(sj["result"]["kind"], "serial");
  EXPECT_TRUE(sj["result"].contains("verdict"));
  EXPECT_FALSE(sj["result"].contains("updated_machine"));
  EXPECT_THROW(service_->studies().SaveJobMachine(serial, ""), Conflict);

  // Hexapod: the stored model; the updated machine becomes version 2.
  const json ids = UploadHexapodTests();
  service_->models().StoreMachineModel(Pm600(), "upload", "");
  const auto hex = km::test::SubmitDiscoveryJson(
      *service_, {{"machine_id", "pm600-like"}, {"measurement_ids", ids}});
  const json hj = WaitForJob(hex);
  ASSERT_EQ(hj["status"], "done") << hj.dump();
  EXPECT_EQ(hj["request"]["machine_version"], 1);
  ASSERT_TRUE(hj["result"].contains("updated_machine")) << hj["result"].dump();
  const auto saved = service_->studies().SaveJobMachine(hex, "discovered");
  EXPECT_TRUE(saved.created);
  EXPECT_EQ(saved.version, 2);
  EXPECT_EQ(service_->models().ListMachineModels("pm600-like")["versions"][1]["source"],
            "discovery job " + to_string(hex));
  EXPECT_EQ(json::parse(service_->models().GetMachineModel("pm600-like").document),
            hj["result"]["updated_machine"]);
  EXPECT_EQ(service_->models().GetMachineModel("pm600-like").document,
            service_->storage().GetJob(hex)->machine_document);

  // Requests are checked like calibration requests, before any job exists.
  const std::size_t jobs = service_->storage().ListJobs(100).size();
  const auto field = [&](const json& request) {
    return Expect<InvalidInput>([&] { km::test::SubmitDiscoveryJson(*service_, request); }).field();
  };
  EXPECT_EQ(field({{"measurement_ids", {ccw, ids[0]}}}), "measurement_ids");  // two machines
  EXPECT_EQ(field({{"measurement_ids", {ccw, cw, ccw}}}), "measurement_ids");
  EXPECT_EQ(field({{"measurement_ids", json::array()}}), "measurement_ids");
  EXPECT_EQ(field({{"machine_version", 1}, {"measurement_ids", {ccw}}}), "machine_version");
  EXPECT_EQ(field({{"machine", json::parse(Pm600())}, {"measurement_ids", ids}}), "machine");
  json many = json::array();
  for (int i = 1; i <= 501; ++i) many.push_back(i);
  const auto e = Expect<InvalidInput>([&] {
    km::test::SubmitDiscoveryJson(*service_, {{"measurement_ids", many}});
  });
  EXPECT_TRUE(Contains(e.what(), "at most 500")) << e.what();
  EXPECT_THROW(km::test::SubmitDiscoveryJson(*service_,
                                             {{"machine_id", "nobody"}, {"measurement_ids", ids}}),
               NotFound);
  EXPECT_THROW(km::test::SubmitDiscoveryJson(*service_, {{"measurement_ids", {ccw, 999}}}),
               NotFound);
  EXPECT_EQ(service_->storage().ListJobs(100).size(), jobs);
}

}  // namespace
}  // namespace km::server
