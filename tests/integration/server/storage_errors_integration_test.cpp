// Integration test: a real kinemetricd whose database another process holds locked answers 503
// with Retry-After (never 500), and serves again once the lock is gone; a database failure it
// cannot recover from is a 500 naming only the request id, the details left in its log.
#include <gtest/gtest.h>
#include <httplib.h>
#include <sqlite3.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/integration/server/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char* kLockToken = "storage-errors-token";

std::string SmallDbb(const std::string& test_id) {
  std::string s = "# format: kinemetric-dbb/1\n# machine_id: lock-vmc\n# test_id: " + test_id +
                  "\n# direction: ccw\n# bar_length_mm: 150\n# centre_mm: 0, 0, 0\n"
                  "# feed_mm_min: 1000\nangle_deg,dr_um\n";
  for (int i = 0; i < 360; ++i) {
    s += std::to_string(i) + "," + std::to_string(0.5 * ((i * 7) % 5) - 1.0) + "\n";
  }
  return s;
}

// A second connection to the server's database, as a backup or maintenance tool would open.
class OtherConnection {
 public:
  explicit OtherConnection(const std::string& path) {
    EXPECT_EQ(sqlite3_open(path.c_str(), &db_), SQLITE_OK);
    sqlite3_busy_timeout(db_, 5000);
  }
  ~OtherConnection() { sqlite3_close(db_); }
  int Exec(const char* sql) { return sqlite3_exec(db_, sql, nullptr, nullptr, nullptr); }

 private:
  sqlite3* db_ = nullptr;
};

class StorageErrorsHttp : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("kinemetric-lock-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    server_ = std::make_unique<km::test::ServerProcess>(KINEMETRICD_BIN, dir_.string(), kLockToken,
                                                        "--db-busy-timeout-ms 100");
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    client_->set_read_timeout(10, 0);
    client_->set_default_headers({{"Authorization", std::string("Bearer ") + kLockToken}});
  }
  void TearDown() override {
    client_.reset();
    server_.reset();
    fs::remove_all(dir_);
  }
  httplib::Result Upload(const std::string& body) {
    return client_->Post("/api/v1/measurements", {{"X-Filename", "lock.dbb"}}, body, "text/plain");
  }
  std::string DbPath() const { return (dir_ / "kinemetric.db").string(); }

  fs::path dir_;
  std::unique_ptr<km::test::ServerProcess> server_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(StorageErrorsHttp, LockedDatabaseIs503WithRetryAfterAndServesAgainAfterwards) {
  if (km::test::OnPostgresql()) {
    GTEST_SKIP() << "SQLite file locking and damage; PostgreSQL's busy and failed calls are "
                    "tested in the storage backend tests";
  }
  auto first = Upload(SmallDbb("before"));
  ASSERT_TRUE(first);
  ASSERT_EQ(first->status, 201) << first->body;

  OtherConnection other(DbPath());
  ASSERT_EQ(other.Exec("BEGIN EXCLUSIVE"), SQLITE_OK);  // holds the write lock
  auto locked = Upload(SmallDbb("during"));
  ASSERT_TRUE(locked);
  EXPECT_EQ(locked->status, 503) << locked->body;
  EXPECT_EQ(locked->get_header_value("Retry-After"), "1");
  EXPECT_EQ(locked->get_header_value("Content-Type"), "application/problem+json");
  const auto problem = json::parse(locked->body);
  EXPECT_EQ(problem["status"], 503);
  EXPECT_EQ(problem["request_id"], locked->get_header_value("X-Request-Id"));
  EXPECT_EQ(locked->body.find("kinemetric.db"), std::string::npos) << locked->body;
  // Reading goes on while another connection writes (WAL).
  auto list = client_->Get("/api/v1/measurements");
  ASSERT_TRUE(list);
  EXPECT_EQ(list->status, 200);
  EXPECT_EQ(json::parse(list->body)["total"], 1);
  ASSERT_EQ(other.Exec("ROLLBACK"), SQLITE_OK);

  // The same request, retried, succeeds; the refused one stored nothing.
  auto retried = Upload(SmallDbb("during"));
  ASSERT_TRUE(retried);
  EXPECT_EQ(retried->status, 201) << retried->body;
  list = client_->Get("/api/v1/measurements");
  ASSERT_TRUE(list);
  EXPECT_EQ(json::parse(list->body)["total"], 2);
}

TEST_F(StorageErrorsHttp, InternalDatabaseFailureIs500WithOnlyTheRequestId) {
  if (km::test::OnPostgresql()) {
    GTEST_SKIP() << "SQLite file locking and damage; PostgreSQL's busy and failed calls are "
                    "tested in the storage backend tests";
  }
  auto jobs = client_->Get("/api/v1/jobs");
  ASSERT_TRUE(jobs);
  ASSERT_EQ(jobs->status, 200);
  OtherConnection other(DbPath());
  ASSERT_EQ(other.Exec("ALTER TABLE jobs RENAME TO jobs_hidden_by_test"), SQLITE_OK);
  auto broken = client_->Get("/api/v1/jobs");
  ASSERT_TRUE(broken);
  EXPECT_EQ(broken->status, 500);
  EXPECT_EQ(broken->get_header_value("Content-Type"), "application/problem+json");
  const auto problem = json::parse(broken->body);
  const std::string id = broken->get_header_value("X-Request-Id");
  EXPECT_FALSE(id.empty());
  EXPECT_EQ(problem["request_id"], id);
  EXPECT_NE(problem["detail"].get<std::string>().find(id), std::string::npos);
  for (const char* internal : {"jobs", "table", "SELECT", "storage", "kinemetric.db"}) {
    EXPECT_EQ(broken->body.find(internal), std::string::npos) << internal << ": " << broken->body;
  }
  ASSERT_EQ(other.Exec("ALTER TABLE jobs_hidden_by_test RENAME TO jobs"), SQLITE_OK);
  jobs = client_->Get("/api/v1/jobs");
  ASSERT_TRUE(jobs);
  EXPECT_EQ(jobs->status, 200);
}

}  // namespace
