// Integration test: two real kinemetricd instances on one PostgreSQL database (--database). The
// same file uploaded to both at once is stored once; what one stores the other lists and
// serves; a PostgreSQL stop, and a table another client holds locked past the busy timeout,
// answer 503 with Retry-After on both (never 500) and they serve again once it is over, without
// a restart of theirs.
#include <gtest/gtest.h>
#include <httplib.h>
#include <libpq-fe.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "tests/integration/server/server_process.h"
#include "tests/unit/server/pg_test_server.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char* kToken = "pg-instances-token";

std::string SmallDbb(const std::string& test_id) {
  std::string s = "# format: kinemetric-dbb/1\n# machine_id: fleet-vmc\n# test_id: " + test_id +
                  "\n# direction: ccw\n# bar_length_mm: 150\n# centre_mm: 0, 0, 0\n"
                  "# feed_mm_min: 1000\nangle_deg,dr_um\n";
  for (int i = 0; i < 360; ++i) {
    s += std::to_string(i) + "," + std::to_string(0.5 * ((i * 7) % 5) - 1.0) + "\n";
  }
  return s;
}

class PgInstances : public ::testing::Test {
 protected:
  void SetUp() override {
    url_ = km::server::test::FreshDatabaseUrl();
    if (url_.empty()) GTEST_SKIP() << "no PostgreSQL server (KINEMETRIC_TEST_DATABASE)";
    base_ = fs::temp_directory_path() / ("kinemetric-pg-" + std::to_string(::getpid()));
    fs::remove_all(base_);
    for (int i = 0; i < 2; ++i) {
      const auto dir = base_ / ("instance" + std::to_string(i));
      fs::create_directories(dir);
      servers_.push_back(std::make_unique<km::test::ServerProcess>(
          KINEMETRICD_BIN, dir.string(), kToken,
          "--db-busy-timeout-ms 500 --db-pool-size 4 --database '" + url_ + "'"));
      clients_.push_back(std::make_unique<httplib::Client>("127.0.0.1", servers_[i]->port()));
      clients_[i]->set_read_timeout(20, 0);
      clients_[i]->set_default_headers({{"Authorization", std::string("Bearer ") + kToken}});
    }
  }
  void TearDown() override {
    clients_.clear();
    servers_.clear();
    fs::remove_all(base_);
  }
  httplib::Result Upload(int instance, const std::string& body) {
    return clients_[instance]->Post("/api/v1/measurements", {{"X-Filename", "fleet.dbb"}}, body,
                                    "text/plain");
  }

  std::string url_;
  fs::path base_;
  std::vector<std::unique_ptr<km::test::ServerProcess>> servers_;
  std::vector<std::unique_ptr<httplib::Client>> clients_;
};

TEST_F(PgInstances, TheSameFileUploadedToBothAtOnceIsStoredOnceAndServedByEither) {
  const std::string body = SmallDbb("shared");
  std::atomic<int> created{0}, again{0};
  std::vector<std::int64_t> ids(8, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      httplib::Client c("127.0.0.1", servers_[t % 2]->port());
      c.set_read_timeout(20, 0);
      c.set_default_headers({{"Authorization", std::string("Bearer ") + kToken}});
      const auto r =
          c.Post("/api/v1/measurements", {{"X-Filename", "fleet.dbb"}}, body, "text/plain");
      if (!r) return;
      if (r->status == 201) ++created;
      if (r->status == 200) ++again;
      ids[t] = json::parse(r->body).value("id", std::int64_t{0});
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(created.load(), 1);
  EXPECT_EQ(again.load(), 7);
  for (const auto id : ids) EXPECT_EQ(id, ids[0]);
  ASSERT_EQ(Upload(1, SmallDbb("second"))->status, 201);
  for (int i = 0; i < 2; ++i) {
    const auto list = clients_[i]->Get("/api/v1/measurements?machine_id=fleet-vmc");
    ASSERT_TRUE(list);
    ASSERT_EQ(list->status, 200) << list->body;
    EXPECT_EQ(json::parse(list->body)["total"], 2) << i;
    const auto one = clients_[i]->Get("/api/v1/measurements/" + std::to_string(ids[0]));
    ASSERT_TRUE(one);
    ASSERT_EQ(one->status, 200) << one->body;
    const auto m = json::parse(one->body);
    EXPECT_EQ(m["test_id"], "shared") << i;
    EXPECT_EQ(m["sample_count"], 360) << i;
  }
}

TEST_F(PgInstances, ADatabaseOutageIs503OnBothAndTheyServeAgainAfterIt) {
  if (!km::server::test::OwnCluster()) GTEST_SKIP() << "not our PostgreSQL server";
  ASSERT_EQ(Upload(0, SmallDbb("before"))->status, 201);
  km::server::test::StopServer();
  for (int i = 0; i < 2; ++i) {
    const auto r = clients_[i]->Get("/api/v1/measurements");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 503) << r->body;
    EXPECT_EQ(r->get_header_value("Retry-After"), "1");
    EXPECT_EQ(r->body.find("postgresql://"), std::string::npos) << r->body;
  }
  km::server::test::StartServer();
  for (int i = 0; i < 2; ++i) {
    const auto r = clients_[i]->Get("/api/v1/measurements");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200) << r->body;
    EXPECT_EQ(json::parse(r->body)["total"], 1);
  }
  EXPECT_EQ(Upload(1, SmallDbb("after"))->status, 201);
}

TEST_F(PgInstances, ATableLockedLongerThanTheBusyTimeoutIs503AndServesAfterwards) {
  ASSERT_EQ(Upload(0, SmallDbb("before"))->status, 201);
  // Another client (a maintenance job) holds the measurements table.
  PGconn* other = PQconnectdb(url_.c_str());
  ASSERT_EQ(PQstatus(other), CONNECTION_OK);
  PQclear(PQexec(other, "BEGIN"));
  PQclear(PQexec(other, "LOCK TABLE measurements IN ACCESS EXCLUSIVE MODE"));
  for (int i = 0; i < 2; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = Upload(i, SmallDbb("locked " + std::to_string(i)));
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 503) << r->body;
    EXPECT_EQ(r->get_header_value("Retry-After"), "1");
    EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(400));
  }
  PQclear(PQexec(other, "ROLLBACK"));
  PQfinish(other);
  EXPECT_EQ(Upload(1, SmallDbb("locked 1"))->status, 201);
  const auto list = clients_[0]->Get("/api/v1/measurements?machine_id=fleet-vmc");
  ASSERT_TRUE(list);
  EXPECT_EQ(json::parse(list->body)["total"], 2);  // nothing of the refused uploads kept
}

}  // namespace
