// The PostgreSQL backend where it differs from an embedded file: several instances on one
// database at once, migrations racing, a newer schema, triggers, a server restart, lock
// timeouts, the connection pool, text PostgreSQL cannot hold, passwords kept out of messages.
#include "server/storage/pg/pg_storage.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <set>
#include <thread>
#include <vector>

#include "analysis/core/errors.h"
#include "server/base/database_url.h"
#include "server/storage/open_storage.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_migrations.h"
#include "tests/unit/server/pg_test_server.h"

namespace km::server {
namespace {

using test::ExecSql;
using test::QueryValue;

class PgStorageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    url_ = test::FreshDatabaseUrl();
    if (url_.empty()) GTEST_SKIP() << "no PostgreSQL server (KINEMETRIC_TEST_DATABASE)";
  }
  static NewMeasurement Sample(const std::string& sha) {
    NewMeasurement m;
    m.sha256 = sha;
    m.kind = "dbb";
    m.format = "kinemetric-dbb/1";
    m.machine_id = "m";
    m.metadata_json = "{}";
    m.raw = "raw " + sha;
    m.samples.columns = {"a"};
    m.samples.values = {1};
    return m;
  }
  std::string url_;
};

TEST_F(PgStorageTest, TwoInstancesStoringTheSameBytesAtOnceGetOneId) {
  PgStorage a(url_), b(url_);
  constexpr int kThreads = 8, kFiles = 20;
  std::vector<std::vector<PutOutcome>> got(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      Storage& s = t % 2 ? static_cast<Storage&>(a) : b;
      for (int f = 0; f < kFiles; ++f) {
        got[t].push_back(s.PutMeasurement(Sample("sha" + std::to_string(f)),
                                          {{"dbb", "dbb/1", std::to_string(t)}}));
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int f = 0; f < kFiles; ++f) {
    int created = 0;
    const auto id = a.FindBySha256("sha" + std::to_string(f));
    ASSERT_TRUE(id);
    for (int t = 0; t < kThreads; ++t) {
      EXPECT_EQ(got[t][f].id, *id);
      created += got[t][f].created ? 1 : 0;
    }
    EXPECT_EQ(created, 1) << f;
    EXPECT_EQ(a.GetResults(*id).size(), 1u);  // the results of the one that stored it
  }
  EXPECT_EQ(QueryValue(url_, "SELECT COUNT(*) FROM measurements"), "20");
  EXPECT_EQ(QueryValue(url_, "SELECT COUNT(*) FROM results"), "20");
}

TEST_F(PgStorageTest, ConcurrentModelVersionsAreNumberedWithoutGapsOrRepeats) {
  PgStorage a(url_), b(url_);
  constexpr int kThreads = 6, kEach = 10;
  std::vector<std::thread> threads;
  std::atomic<int> created{0};
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      Storage& s = t % 2 ? static_cast<Storage&>(a) : b;
      for (int i = 0; i < kEach; ++i) {
        const std::string doc = "doc " + std::to_string(t) + "/" + std::to_string(i);
        if (s.PutMachineModel({"hx", "upload", "", doc, "sha " + doc}).created) ++created;
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(created.load(), kThreads * kEach);
  const auto list = a.ListMachineModels("hx");
  ASSERT_EQ(list.size(), static_cast<std::size_t>(kThreads * kEach));
  std::set<std::string> docs;
  for (std::size_t i = 0; i < list.size(); ++i) {
    EXPECT_EQ(list[i].version, static_cast<std::int64_t>(i + 1));
    docs.insert(list[i].sha256);
  }
  EXPECT_EQ(docs.size(), list.size());
}

TEST_F(PgStorageTest, InstancesStartingAtOnceMigrateOnce) {
  std::vector<std::thread> threads;
  std::atomic<int> ok{0};
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      PgStorage s(url_);
      ++ok;
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(ok.load(), 4);
  EXPECT_EQ(QueryValue(url_, "SELECT COUNT(*) FROM kinemetric_schema"), "1");
  EXPECT_EQ(QueryValue(url_, "SELECT version FROM kinemetric_schema"),
            std::to_string(PgStorage::SchemaVersion()));
  EXPECT_EQ(PgStorage::SchemaVersion(), 14);
  // The instrument register (migration 12).
  EXPECT_EQ(QueryValue(url_, "SELECT COUNT(*) FROM instruments"), "0");
  // When each token was last used (migration 10).
  EXPECT_EQ(QueryValue(url_,
                       "SELECT COUNT(*) FROM information_schema.columns WHERE table_name = "
                       "'tokens' AND column_name = 'last_used_at'"),
            "1");
  // The job-queue columns and the job's owner are there.
  EXPECT_EQ(QueryValue(url_,
                       "SELECT COUNT(*) FROM information_schema.columns WHERE table_name = 'jobs' "
                       "AND column_name IN ('plan_json', 'lease_owner', 'lease_until_ms', "
                       "'attempts', 'owner_token_id')"),
            "5");
}

TEST_F(PgStorageTest, ADatabaseOfANewerSchemaIsRefusedUntouched) {
  { PgStorage s(url_); }
  ASSERT_EQ(ExecSql(url_, "UPDATE kinemetric_schema SET version = 99"), "");
  try {
    PgStorage s(url_);
    FAIL() << "a newer schema was opened";
  } catch (const StorageError& e) {
    EXPECT_FALSE(e.busy());
    EXPECT_NE(std::string(e.what()).find("newer than this program"), std::string::npos) << e.what();
  }
  EXPECT_EQ(QueryValue(url_, "SELECT version FROM kinemetric_schema"), "99");
}

TEST_F(PgStorageTest, ADatabaseOfVersion7GainsTheJobQueueWithNothingLost) {
  {
    pg::ConnOptions o;
    o.url = url_;
    pg::Conn c(o);
    pg::Migrate(c, 7);
  }
  EXPECT_EQ(QueryValue(url_, "SELECT version FROM kinemetric_schema"), "7");
  ASSERT_EQ(ExecSql(url_,
                    "INSERT INTO jobs (kind, status, request_json, result_json, created_at, "
                    "updated_at) VALUES ('calibration', 'done', '{\"a\":1}', '{\"r\":2}', "
                    "'2026-01-01T00:00:00Z', '2026-01-01T00:00:01Z');"
                    "INSERT INTO tokens (token_sha256, role, created_at) VALUES ('h', 'admin', "
                    "'2026-01-01T00:00:00Z')"),
            "");
  PgStorage s(url_);
  EXPECT_EQ(QueryValue(url_, "SELECT version FROM kinemetric_schema"),
            std::to_string(pg::SchemaVersion()));
  const auto j = *s.GetJob(JobId(1));
  EXPECT_EQ(j.status, JobStatus::kDone);
  EXPECT_EQ(j.request_json, R"({"a":1})");
  EXPECT_EQ(j.result_json, R"({"r":2})");
  EXPECT_EQ(j.updated_at, "2026-01-01T00:00:01Z");
  EXPECT_EQ(j.plan_json, "");
  EXPECT_EQ(j.lease_owner, "");
  EXPECT_EQ(j.lease_until_ms, 0);
  EXPECT_EQ(j.attempts, 0);
  EXPECT_EQ(s.FindTokenRole("h"), "admin");
  EXPECT_EQ(s.QueueJob({"discovery", "{}", "{}"}), JobId(2));
}

TEST_F(PgStorageTest, KeptRowsAreImmutableInTheDatabaseItself) {
  {
    PgStorage s(url_);
    s.PutMeasurement(Sample("a"), {});
    s.PutMachineModel({"hx", "upload", "", "doc", "sha"});
    const auto id = s.CreateStream({"m", "", "http", "{}"});
    StreamChunk c;
    c.stream_id = id;
    c.n = 1;
    c.data = "x";
    s.AppendStream({c}, {});
    s.AppendAudit({AuditEntryId(), "", std::nullopt, "", "admin", "POST", "/x", 200, ""});
    s.AddAuditVerdict({AuditVerdictId(), "m", 2, "manual", "", "{}", "pending", 0});
  }
  for (const char* table :
       {"measurements", "stream_chunks", "machine_models", "audit_log", "audit_verdicts"}) {
    const std::string t = table;
    EXPECT_NE(ExecSql(url_, "DELETE FROM " + t), "") << t;
    EXPECT_NE(ExecSql(url_, "TRUNCATE " + t + " CASCADE"), "") << t;
    EXPECT_NE(ExecSql(url_, "UPDATE " + t + " SET id = id + 100"), "") << t;
    EXPECT_EQ(QueryValue(url_, "SELECT COUNT(*) FROM " + t + " WHERE id = 1"), "1") << t;
  }
  EXPECT_NE(ExecSql(url_, "UPDATE audit_verdicts SET verdict_json = '[]'"), "");
  EXPECT_EQ(ExecSql(url_, "UPDATE audit_verdicts SET webhook_status = 'delivered'"), "");
  EXPECT_NE(ExecSql(url_, "UPDATE measurements SET machine_id = 'x'").find("immutable"),
            std::string::npos);
}

TEST_F(PgStorageTest, AServerRestartFailsCallsBusyMeanwhileAndTheyWorkAfter) {
  if (!test::OwnCluster()) GTEST_SKIP() << "the server of KINEMETRIC_TEST_DATABASE is not ours";
  PgOptions o;
  o.busy_timeout_ms = 1000;
  o.pool_size = 3;
  PgStorage s(url_, o);
  const auto id = s.PutMeasurement(Sample("before"), {}).id;
  // Every connection of the pool opened and idle when the server goes.
  std::vector<std::thread> readers;
  for (int t = 0; t < 3; ++t) readers.emplace_back([&] { s.GetMeasurement(id); });
  for (auto& th : readers) th.join();
  test::StopServer();
  for (int i = 0; i < 4; ++i) {
    try {
      s.GetMeasurement(id);
      ADD_FAILURE() << "a call succeeded without a server";
    } catch (const StorageError& e) {
      EXPECT_TRUE(e.busy()) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind("storage: ", 0), 0u) << e.what();
    }
  }
  EXPECT_THROW(s.PutMeasurement(Sample("during"), {}), StorageError);
  test::StartServer();
  EXPECT_EQ(s.GetMeasurement(id)->sha256, "before");
  EXPECT_TRUE(s.PutMeasurement(Sample("after"), {}).created);
  // pg_ctl restart: the pool's idle connections are found closed and opened again.
  std::vector<std::thread> again;
  for (int t = 0; t < 3; ++t) again.emplace_back([&] { s.ListMachines(); });
  for (auto& th : again) th.join();
  test::RestartServer();
  for (int i = 0; i < 5; ++i) EXPECT_EQ(s.GetMeasurement(id)->sha256, "before") << i;
  EXPECT_FALSE(s.PutMeasurement(Sample("after"), {}).created);
}

TEST_F(PgStorageTest, CallsDuringARestartUnderLoadSucceedOrFailBusyOnly) {
  if (!test::OwnCluster()) GTEST_SKIP() << "the server of KINEMETRIC_TEST_DATABASE is not ours";
  PgOptions o;
  o.busy_timeout_ms = 1000;
  o.pool_size = 4;
  PgStorage s(url_, o);
  std::atomic<bool> stop{false};
  std::atomic<int> ok{0}, busy{0}, other{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; !stop; ++i) {
        try {
          s.PutMeasurement(Sample("t" + std::to_string(t) + "-" + std::to_string(i)), {});
          s.ListMachines();
          ++ok;
        } catch (const StorageError& e) {
          ++(e.busy() ? busy : other);
        } catch (...) {
          ++other;
        }
      }
    });
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  test::RestartServer();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const int ok_after_restart = ok.load();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  stop = true;
  for (auto& th : threads) th.join();
  std::printf("during a restart under load: %d calls served, %d busy\n", ok.load(), busy.load());
  EXPECT_EQ(other.load(), 0);
  EXPECT_GT(ok.load(), ok_after_restart);  // served again after the restart
  // Every acknowledged store is there, once.
  EXPECT_EQ(QueryValue(url_, "SELECT COUNT(*) = COUNT(DISTINCT sha256) FROM measurements"), "t");
  EXPECT_GE(std::stoi(QueryValue(url_, "SELECT COUNT(*) FROM measurements")), ok.load());
}

// Another session holding the jobs table exclusively (a transaction of its own thread) until
// the object is destroyed.
class JobsTableLock {
 public:
  explicit JobsTableLock(const std::string& url)
      : holder_([this, url] {
          PGconn* c = PQconnectdb(url.c_str());
          PQclear(PQexec(c, "BEGIN"));
          PQclear(PQexec(c, "LOCK TABLE jobs IN ACCESS EXCLUSIVE MODE"));
          locked_ = true;
          while (!release_) std::this_thread::sleep_for(std::chrono::milliseconds(5));
          PQclear(PQexec(c, "ROLLBACK"));
          PQfinish(c);
        }) {
    while (!locked_) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ~JobsTableLock() { Release(); }
  void Release() {
    release_ = true;
    if (holder_.joinable()) holder_.join();
  }

 private:
  std::atomic<bool> locked_{false}, release_{false};
  std::thread holder_;
};

TEST_F(PgStorageTest, ALockHeldLongerThanTheBusyTimeoutIsBusy) {
  PgOptions o;
  o.busy_timeout_ms = 200;
  PgStorage s(url_, o);
  const auto job = s.CreateJob("calibration", "{}");
  JobsTableLock lock(url_);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    s.GetJob(job);
    ADD_FAILURE() << "read through an exclusive lock";
  } catch (const StorageError& e) {
    EXPECT_TRUE(e.busy());
    EXPECT_EQ(e.code(), pg::SqlStateCode("55P03")) << e.what();
  }
  const auto waited = std::chrono::steady_clock::now() - t0;
  EXPECT_GE(waited, std::chrono::milliseconds(150));
  EXPECT_LT(waited, std::chrono::seconds(3));
  // A statement timeout shorter than the lock wait: busy as well (57014).
  PgOptions t;
  t.busy_timeout_ms = 5000;
  t.statement_timeout_ms = 200;
  PgStorage slow(url_, t);
  try {
    slow.GetJob(job);
    ADD_FAILURE() << "read through an exclusive lock";
  } catch (const StorageError& e) {
    EXPECT_TRUE(e.busy());
    EXPECT_EQ(e.code(), pg::SqlStateCode("57014")) << e.what();
  }
  lock.Release();
  EXPECT_EQ(s.GetJob(job)->status, JobStatus::kQueued);
}

TEST_F(PgStorageTest, ErrorsAreBusyForTheSqlStatesARetryMayOutlast) {
  pg::ConnOptions o;
  o.url = url_;
  pg::Conn c(o);
  const std::pair<const char*, bool> states[] = {
      {"40001", true},  {"40P01", true},  {"55P03", true},  {"57014", true},
      {"08006", true},  {"57P01", true},  {"57P03", true},  {"23505", false},
      {"42P01", false}, {"P0001", false}, {"53100", false}, {"22021", false}};
  for (const auto& [state, busy] : states) {
    try {
      c.Exec(std::string("DO $$ BEGIN RAISE EXCEPTION 'raised' USING ERRCODE = '") + state +
                 "'; END $$",
             "raise");
      ADD_FAILURE() << state << " raised nothing";
    } catch (const StorageError& e) {
      EXPECT_EQ(e.busy(), busy) << state;
      EXPECT_EQ(e.code(), pg::SqlStateCode(state)) << state;
      EXPECT_EQ(std::string(e.what()), "storage: raise: raised") << state;
    }
  }
  EXPECT_EQ(pg::SqlStateCode("40001"), (((4 * 36 + 0) * 36 + 0) * 36 + 0) * 36 + 1);
}

TEST_F(PgStorageTest, ThePoolBoundsTheConnectionsAndServesManyThreads) {
  PgOptions o;
  o.pool_size = 2;
  PgStorage s(url_, o);
  const std::string db = url_.substr(url_.rfind('/') + 1);
  const std::string open_connections = "SELECT COUNT(*) FROM pg_stat_activity WHERE datname = '" +
                                       db + "' AND application_name = 'kinemetricd'";
  EXPECT_EQ(QueryValue(url_, open_connections), "2");  // all opened at start
  const auto id = s.PutMeasurement(Sample("p"), {}).id;
  std::atomic<int> ok{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 25; ++i) ok += s.GetMeasurement(id) ? 1 : 0;
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(ok.load(), 200);
  EXPECT_EQ(QueryValue(url_, open_connections), "2");
}

TEST_F(PgStorageTest, TextPostgreSqlCannotHoldIsRefusedNamingTheField) {
  PgStorage s(url_);
  NewMeasurement m = Sample("nul");
  m.filename = std::string("a\0b", 3);
  try {
    s.PutMeasurement(m, {});
    ADD_FAILURE() << "a NUL byte was stored";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "filename");
  }
  EXPECT_FALSE(s.FindBySha256("nul"));
  EXPECT_THROW(s.CreateStream({"m", std::string("\0", 1), "http", "{}"}), InvalidInput);
  EXPECT_THROW(s.PutMachineModel({"m", "upload", std::string("n\0", 2), "d", "s"}), InvalidInput);
  // A machine id longer than an index entry holds: refused naming it; 2048 bytes (of letters
  // that do not compress) are stored and found.
  std::string id;
  std::uint32_t x = 12345;
  while (id.size() < 3000) {
    x = x * 1103515245u + 12345u;
    id += static_cast<char>('a' + (x >> 16) % 26);
  }
  m = Sample("long");
  m.machine_id = id;
  try {
    s.PutMeasurement(m, {});
    ADD_FAILURE() << "a 3000-byte machine id was taken";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "machine_id");
  }
  EXPECT_THROW(s.CreateStream({id, "", "http", "{}"}), InvalidInput);
  m.machine_id = id.substr(0, 2048);
  EXPECT_TRUE(s.PutMeasurement(m, {}).created);
  MeasurementFilter f;
  f.machine_id = m.machine_id;
  EXPECT_EQ(s.ListMeasurements(f).total, 1);
  EXPECT_EQ(s.CreateStream({m.machine_id, "", "http", "{}"}).value(), 1);
  EXPECT_TRUE(s.PutMachineModel({m.machine_id, "upload", "", "d", "s"}).created);
}

TEST_F(PgStorageTest, MessagesNeverShowThePassword) {
  PgOptions o;
  o.busy_timeout_ms = 1000;
  try {
    PgStorage s("postgresql://kinemetric:s3cret@127.0.0.1:1/x", o);
    FAIL() << "connected to port 1";
  } catch (const StorageError& e) {
    EXPECT_EQ(std::string(e.what()).find("s3cret"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("kinemetric:***@127.0.0.1:1/x"), std::string::npos)
        << e.what();
    EXPECT_TRUE(e.busy());
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();  // one log line
  }
  EXPECT_EQ(MaskPassword("postgres://u:p%40ss@h/db?sslmode=require"),
            "postgres://u:***@h/db?sslmode=require");
  EXPECT_EQ(MaskPassword("postgresql://h/db?user=u&password=x&sslmode=require"),
            "postgresql://h/db?user=u&password=***&sslmode=require");
  EXPECT_EQ(MaskPassword("postgresql://u@h:5432/db"), "postgresql://u@h:5432/db");
}

TEST_F(PgStorageTest, TheFactoryOpensTheBackendOfTheConfiguration) {
  ServerConfig cfg;
  cfg.database = url_;
  cfg.db_pool_size = 3;
  auto s = OpenStorage(cfg);
  ASSERT_NE(dynamic_cast<PgStorage*>(s.get()), nullptr);
  EXPECT_EQ(s->PutMeasurement(Sample("f"), {}).id, MeasurementId(1));
  EXPECT_EQ(DescribeDatabase(cfg), "PostgreSQL " + url_);
  cfg.database = "mysql://x";
  EXPECT_THROW(OpenStorage(cfg), InvalidInput);
}

TEST_F(PgStorageTest, TheConfiguredStatementTimeoutCancelsALongStatement) {
  ServerConfig cfg;
  cfg.database = url_;
  cfg.db_busy_timeout_ms = 5000;
  cfg.db_statement_timeout_ms = 200;
  auto s = OpenStorage(cfg);
  const auto job = s->CreateJob("calibration", "{}");
  JobsTableLock lock(url_);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    s->GetJob(job);
    ADD_FAILURE() << "read through an exclusive lock";
  } catch (const StorageError& e) {
    EXPECT_TRUE(e.busy());
    EXPECT_EQ(e.code(), pg::SqlStateCode("57014")) << e.what();
  }
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(3));
}

}  // namespace
}  // namespace km::server
