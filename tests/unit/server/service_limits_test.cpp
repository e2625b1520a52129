// What a client sends is bounded before it costs memory or CPU: calibration requests (number of
// tests, repeated ids, tests of one machine, no reduction study with effects, nothing read before
// the job runs, each test read once), who may cancel a job, and uploads
// (per-format limits of rows, line length and columns, checked before parsing; the format line
// checked before it is used).
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "analysis/core/errors.h"
#include "ingest/text_format.h"
#include "server/base/errors.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/expect_error.h"
#include "tests/unit/server/study_request_json.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

// SQLite storage that counts the measurement files read, and on which thread.
class CountingStorage final : public SqliteStorage {
 public:
  explicit CountingStorage(const std::string& path) : SqliteStorage(path) {}

  std::size_t RawReads() const { return raw_reads_.load(); }
  std::size_t RawReadsOn(std::thread::id thread) {
    std::lock_guard<std::mutex> lock(mu_);
    return by_thread_[thread];
  }
  std::multiset<std::int64_t> RawIds() {
    std::lock_guard<std::mutex> lock(mu_);
    return ids_;
  }

  std::string GetRaw(MeasurementId id) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      ++by_thread_[std::this_thread::get_id()];
      ids_.insert(id.value());
    }
    ++raw_reads_;
    return SqliteStorage::GetRaw(id);
  }

 private:
  std::atomic<std::size_t> raw_reads_{0};
  std::mutex mu_;
  std::map<std::thread::id, std::size_t> by_thread_;
  std::multiset<std::int64_t> ids_;
};

std::string ReadFile(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A service on a fresh SQLite file, removed at the end.
class ServiceLimits : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    db_ = fs::temp_directory_path() /
          ("km-limits-" + std::to_string(::getpid()) + "-" + info->name() + ".db");
    Remove();
  }
  void TearDown() override {
    service_.reset();
    Remove();
  }
  void Start(ServiceOptions options = {}) {
    auto storage = std::make_unique<CountingStorage>(db_.string());
    storage_ = storage.get();
    service_ = std::make_unique<Service>(std::move(storage), options);
    RegisterBuiltinKinds(service_->measurements());
  }
  void Remove() {
    for (const char* ext : {"", "-wal", "-shm"}) fs::remove(db_.string() + ext);
  }
  // The ten hexapod DBB fixtures (with tool length and fixed ball), uploaded; their ids.
  std::vector<std::int64_t> UploadHexapodTests() {
    std::vector<std::int64_t> ids;
    for (char c = 'a'; c <= 'j'; ++c) {
      const std::string name = std::string("dbb_") + c + "_ccw.txt";
      const auto out = service_->measurements().Upload(
          ReadFile(fs::path("tests/fixtures/browser/hexapod") / name), name);
      ids.push_back(out.id.value());
    }
    return ids;
  }
  nlohmann::json Request(const nlohmann::json& ids) {
    return {{"machine", nlohmann::json::parse(ReadFile("tests/fixtures/pm600-like.json"))},
            {"measurement_ids", ids}};
  }
  nlohmann::json WaitForJob(JobId id) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::minutes(5);
    while (std::chrono::steady_clock::now() < until) {
      const auto j = service_->studies().Job(id);
      if (j["status"] == "done" || j["status"] == "failed") return j;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "job " << id << " did not finish";
    return service_->studies().Job(id);
  }

  fs::path db_;
  CountingStorage* storage_ = nullptr;
  std::unique_ptr<Service> service_;
};

using km::test::Contains;
using km::test::Expect;

TEST_F(ServiceLimits, TooManyCalibrationTestsAreRefusedBeforeAnythingIsRead) {
  Start();
  const auto ids = UploadHexapodTests();
  // 5 000 ids, the same ten over and over: refused at once, naming the field and the limit
  // (each id used to be read and parsed: 100 000 of them took 1.5 GB).
  nlohmann::json many = nlohmann::json::array();
  for (int i = 0; i < 5'000; ++i) many.push_back(ids[static_cast<std::size_t>(i % 10)]);
  const auto e =
      Expect<InvalidInput>([&] { km::test::SubmitCalibrationJson(*service_, Request(many)); });
  EXPECT_EQ(e.field(), "measurement_ids");
  EXPECT_TRUE(Contains(e.what(), "500")) << e.what();
  EXPECT_TRUE(Contains(e.what(), "5000 ids")) << e.what();
  // One more than the limit, all distinct ids (most do not exist): the count is refused first.
  nlohmann::json over = nlohmann::json::array();
  for (int i = 1; i <= 501; ++i) over.push_back(i);
  const auto e2 =
      Expect<InvalidInput>([&] { km::test::SubmitCalibrationJson(*service_, Request(over)); });
  EXPECT_EQ(e2.field(), "measurement_ids");
  EXPECT_TRUE(Contains(e2.what(), "at most 500")) << e2.what();
  EXPECT_EQ(storage_->RawReads(), 0u);
}

TEST_F(ServiceLimits, TheLimitOfCalibrationTestsIsConfiguration) {
  ServiceOptions o;
  o.max_calibration_tests = 3;
  Start(o);
  const auto ids = UploadHexapodTests();
  const auto e = Expect<InvalidInput>([&] {
    km::test::SubmitCalibrationJson(*service_, Request({ids[0], ids[1], ids[2], ids[3]}));
  });
  EXPECT_EQ(e.field(), "measurement_ids");
  EXPECT_TRUE(Contains(e.what(), "at most 3")) << e.what();
}

TEST_F(ServiceLimits, RepeatedOrMalformedIdsAreRefused) {
  Start();
  const auto ids = UploadHexapodTests();
  const auto e = Expect<InvalidInput>([&] {
    km::test::SubmitCalibrationJson(*service_, Request({ids[0], ids[1], ids[0]}));
  });
  EXPECT_EQ(e.field(), "measurement_ids");
  EXPECT_TRUE(Contains(e.what(), "listed twice (entries 1 and 3)")) << e.what();
  for (const nlohmann::json& bad : {nlohmann::json(0), nlohmann::json(-3), nlohmann::json(1.5),
                                    nlohmann::json("1"), nlohmann::json(18446744073709551615ull)}) {
    SCOPED_TRACE(bad.dump());
    const auto e2 = Expect<InvalidInput>([&] {
      km::test::SubmitCalibrationJson(*service_, Request({ids[0], bad}));
    });
    EXPECT_EQ(e2.field(), "measurement_ids");
    EXPECT_TRUE(Contains(e2.what(), "entry 2")) << e2.what();
  }
  // A missing test and a test without tool length are found from the stored records.
  EXPECT_THROW(km::test::SubmitCalibrationJson(*service_, Request({ids[0], 999})), NotFound);
  std::string no_tool = ReadFile("tests/fixtures/browser/hexapod/dbb_a_ccw.txt");
  const auto tool = no_tool.find("# tool_length_mm");
  no_tool.erase(tool, no_tool.find('\n', tool) - tool + 1);
  const auto plain = service_->measurements().Upload(no_tool, "no_tool.txt").id;
  const auto e3 = Expect<InvalidInput>([&] {
    km::test::SubmitCalibrationJson(*service_, Request({ids[0], plain}));
  });
  EXPECT_EQ(e3.field(), "tool_length_mm");
  EXPECT_EQ(storage_->RawReads(), 0u);
}

TEST_F(ServiceLimits, TheSamplesOfAStudyAreBounded) {
  ServiceOptions o;
  o.max_calibration_samples = 1000;  // the fixtures hold about 190 samples each
  Start(o);
  const auto ids = UploadHexapodTests();
  const auto e =
      Expect<InvalidInput>([&] { km::test::SubmitCalibrationJson(*service_, Request(ids)); });
  EXPECT_EQ(e.field(), "measurement_ids");
  EXPECT_TRUE(Contains(e.what(), "at most 1000")) << e.what();
  EXPECT_EQ(storage_->RawReads(), 0u);
}

TEST_F(ServiceLimits, AQueuedStudyHoldsIdsAndTheJobReadsEachTestOnce) {
  Start();
  const auto ids = UploadHexapodTests();
  ASSERT_EQ(storage_->RawReads(), 0u);
  const auto job = km::test::SubmitCalibrationJson(*service_, Request(ids));
  // Nothing was read while the request was checked: the job reads the tests when it runs.
  EXPECT_EQ(storage_->RawReadsOn(std::this_thread::get_id()), 0u);
  const auto j = WaitForJob(job);
  EXPECT_EQ(j["status"], "done") << j.dump();
  // Each test was read exactly once.
  EXPECT_EQ(storage_->RawReads(), ids.size());
  const auto read = storage_->RawIds();
  for (const auto id : ids) EXPECT_EQ(read.count(id), 1u) << id;
}

TEST_F(ServiceLimits, ACalibrationOfTheTestsOfTwoMachinesIsRefusedBeforeItIsQueued) {
  Start();
  const auto ids = UploadHexapodTests();
  std::string other = ReadFile("tests/fixtures/browser/hexapod/dbb_b_ccw.txt");
  const std::string line = "# machine_id: pm600-like";
  other.replace(other.find(line), line.size(), "# machine_id: pm600-other");
  const auto foreign = service_->measurements().Upload(other, "other.txt").id;
  const auto e = Expect<InvalidInput>([&] {
    km::test::SubmitCalibrationJson(*service_, Request({ids[0], ids[1], foreign}));
  });
  EXPECT_EQ(e.field(), "measurement_ids");
  EXPECT_TRUE(Contains(e.what(), "of 'pm600-other'")) << e.what();
  EXPECT_TRUE(Contains(e.what(), "a calibration study takes the DBB tests of one machine"))
      << e.what();
  EXPECT_TRUE(service_->studies().Jobs(10)["items"].empty());
  EXPECT_EQ(storage_->RawReads(), 0u);
}

TEST_F(ServiceLimits, AReductionStudyWithEffectsIsRefusedBeforeItIsQueued) {
  ServiceOptions o;
  o.jobs.workers = 0;  // nothing runs: a queued job would show
  Start(o);
  const auto ids = UploadHexapodTests();
  nlohmann::json named = Request(ids);
  named["reduction_study_min_tests"] = 4;
  named["effects"] = nlohmann::json::array({"gravity_deflection"});
  const auto e = Expect<InvalidInput>([&] { km::test::SubmitCalibrationJson(*service_, named); });
  EXPECT_EQ(e.field(), "reduction_study_min_tests");
  EXPECT_TRUE(Contains(e.what(), "plain calibration only")) << e.what();
  // The model's own effects take part too: the same refusal.
  nlohmann::json own = Request(ids);
  own["machine"]["effects"] =
      nlohmann::json::array({nlohmann::json{{"effect", "tool_length_error"}}});
  own["reduction_study_min_tests"] = 4;
  const auto e2 = Expect<InvalidInput>([&] { km::test::SubmitCalibrationJson(*service_, own); });
  EXPECT_EQ(e2.field(), "reduction_study_min_tests");
  EXPECT_TRUE(Contains(e2.what(), "has effects of its own")) << e2.what();
  EXPECT_TRUE(service_->studies().Jobs(10)["items"].empty());
  // Each alone is accepted.
  named.erase("reduction_study_min_tests");
  EXPECT_GT(km::test::SubmitCalibrationJson(*service_, named).value(), 0);
  own.erase("reduction_study_min_tests");
  EXPECT_GT(km::test::SubmitCalibrationJson(*service_, own).value(), 0);
  nlohmann::json plain = Request(ids);
  plain["reduction_study_min_tests"] = 4;
  EXPECT_GT(km::test::SubmitCalibrationJson(*service_, plain).value(), 0);
}

TEST_F(ServiceLimits, AJobIsCancelledByItsOwnerOrAnAdminOnly) {
  ServiceOptions o;
  o.jobs.workers = 0;  // the jobs stay queued
  Start(o);
  const auto ids = UploadHexapodTests();
  const auto job =
      km::test::SubmitCalibrationJson(*service_, Request({ids[0], ids[1]}), TokenId(5));
  EXPECT_EQ(service_->studies().Job(job)["owner_token_id"], 5);
  const auto e = Expect<Forbidden>([&] {
    service_->studies().CancelJob(job, {TokenId(6), "other", false});
  });
  EXPECT_TRUE(Contains(e.what(), "only its owner or an admin")) << e.what();
  EXPECT_EQ(service_->studies().Job(job)["status"], "queued");
  const auto j = service_->studies().CancelJob(job, {TokenId(5), "alice", false});
  EXPECT_EQ(j["status"], "cancelled");
  EXPECT_EQ(j["stage"], "cancelled");
  EXPECT_EQ(j["error"], "cancelled by token 'alice' (id 5)");
  EXPECT_TRUE(j["verdict"].is_null());
  const auto again = Expect<Conflict>([&] {
    service_->studies().CancelJob(job, {TokenId(5), "alice", false});
  });
  EXPECT_TRUE(Contains(again.what(), "is cancelled already")) << again.what();
  EXPECT_THROW(service_->studies().CancelJob(JobId(job.value() + 100), {TokenId(1), "admin", true}),
               NotFound);
  // An admin cancels any job, also one whose owner is not known (queued by an older version).
  const auto other = km::test::SubmitDiscoveryJson(*service_, {{"measurement_ids", {ids[0]}}});
  EXPECT_TRUE(service_->studies().Job(other)["owner_token_id"].is_null());
  EXPECT_THROW(service_->studies().CancelJob(other, {TokenId(5), "alice", false}), Forbidden);
  EXPECT_EQ(service_->studies().CancelJob(other, {TokenId(1), "root", true})["error"],
            "cancelled by token 'root' (id 1)");
}

// A DBB file of `samples` rows.
std::string DbbFile(int samples, const std::string& extra_header = "") {
  std::string s =
      "# format: kinemetric-dbb/1\n# machine_id: m1\n# test_id: t\n# direction: ccw\n"
      "# bar_length_mm: 150\n# centre_mm: 0, 0, 0\n# feed_mm_min: 1000\n" +
      extra_header + "angle_deg,dr_um\n";
  for (int i = 0; i < samples; ++i) {
    s += std::to_string(360.0 * i / samples) + "," + std::to_string(0.5 * (i % 7)) + "\n";
  }
  return s;
}

TEST_F(ServiceLimits, UploadsBeyondTheLimitsOfTheirFormatAreRefusedBeforeParsing) {
  ServiceOptions o;
  o.upload_limits["kinemetric-dbb/1"].max_rows = 100;
  o.upload_limits["kinemetric-dbb/1"].max_line_bytes = 200;
  o.upload_limits["kinemetric-dbb/1"].max_columns = 3;
  Start(o);
  EXPECT_TRUE(service_->measurements().Upload(DbbFile(100), "ok.txt").created);
  // Row 101 is line 8 (header) + 101; the rest of the file is never looked at.
  std::string rows = DbbFile(200);
  rows += std::string(10'000, 'x');
  const auto e = Expect<TooLarge>([&] { service_->measurements().Upload(rows, "rows.txt"); });
  EXPECT_EQ(e.file(), "rows.txt");
  EXPECT_EQ(e.line(), 8u + 101u) << e.what();
  EXPECT_TRUE(Contains(e.what(), "100 data rows")) << e.what();
  const auto e2 = Expect<TooLarge>([&] {
    service_->measurements().Upload(DbbFile(50, "# note: " + std::string(300, 'n') + "\n"),
                                    "long.txt");
  });
  EXPECT_EQ(e2.line(), 8u) << e2.what();
  const auto e3 = Expect<TooLarge>([&] {
    std::string f = DbbFile(50);
    f.replace(f.find("angle_deg,dr_um"), 15, "angle_deg,dr_um,a,b");
    service_->measurements().Upload(f, "cols.txt");
  });
  EXPECT_EQ(e3.line(), 8u) << e3.what();
  EXPECT_EQ(service_->storage().ListMeasurements({}).total, 1);
  // The default limits of every built-in format are configuration.
  const auto defaults = DefaultUploadLimits();
  EXPECT_EQ(defaults.at("kinemetric-dbb/1").max_rows, 500'000u);
  EXPECT_EQ(defaults.at("kinemetric-straightness/1").max_rows, 100'000u);
  EXPECT_EQ(defaults.at("kinemetric-tracker/1").max_rows, 10'000u);
  for (const auto& f : service_->measurements().Formats()) EXPECT_TRUE(defaults.count(f)) << f;
}

TEST_F(ServiceLimits, TheFormatLineIsCheckedBeforeItIsUsed) {
  Start();
  for (const std::string& bad :
       {std::string("# format: kinemetric-\xff\xfe/1\nangle_deg,dr_um\n"),
        std::string("# format: kinemetric-dbb/1 \x1b[2J\n"),
        "# format: " + std::string(100'000, 'k') + "/1\n", std::string(100'000, '#') + "\n"}) {
    const auto e = Expect<InvalidInput>([&] { service_->measurements().Upload(bad, "f.txt"); });
    EXPECT_EQ(e.field(), "format") << e.what();
    std::size_t at = 0;
    EXPECT_TRUE(ingest::ValidUtf8(e.what(), at)) << e.what();
    EXPECT_LT(std::string(e.what()).size(), 400u);
    EXPECT_EQ(std::string(e.what()).find('\x1b'), std::string::npos);
  }
}

}  // namespace
}  // namespace km::server
