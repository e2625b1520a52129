// Server options and config-file keys: every number is a whole number within its range, or the
// start is refused naming the option (a server with 0 threads never answers; a negative upload
// limit used to wrap around to 16 EiB).
#include "server/base/config.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server {
namespace {

class ServerConfigTest : public test::TempDirTest {
 protected:
  std::string File(const std::string& json) {
    const std::string p = Path("config.json");
    std::ofstream(p) << json;
    return p;
  }
  // Expects InvalidInput naming `field` (and the file when `file` is set).
  static void ExpectRefused(const std::vector<std::string>& args, const std::string& field,
                            const std::string& file = "") {
    try {
      const auto cfg = ParseServerArgs(args);
      ADD_FAILURE() << "accepted " << ::testing::PrintToString(args) << " (threads " << cfg.threads
                    << ", max_upload_bytes " << cfg.max_upload_bytes << ")";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), field) << e.what();
      EXPECT_EQ(e.file(), file) << e.what();
    }
  }
};

TEST_F(ServerConfigTest, AcceptsSensibleOptions) {
  const auto cfg = ParseServerArgs({"--listen", "0.0.0.0:9000", "--threads", "256",
                                    "--max-upload-bytes", "4294967296", "--data-dir", "d"});
  EXPECT_EQ(cfg.host, "0.0.0.0");
  EXPECT_EQ(cfg.port, 9000);
  EXPECT_EQ(cfg.threads, 256);
  EXPECT_EQ(cfg.max_upload_bytes, std::size_t{4} << 30);
  EXPECT_EQ(ParseServerArgs({"--threads", "1", "--max-upload-bytes", "1"}).threads, 1);
  EXPECT_EQ(ParseServerArgs({"--listen", "127.0.0.1:0"}).port, 0);  // any free port
  EXPECT_EQ(ParseServerArgs({"--listen", "[::1]:8080"}).host, "::1");

  const auto f = ParseServerArgs({"--config", File(R"({"threads": 3, "queue_limit": 1,
      "read_timeout_s": 1, "write_timeout_s": 3600, "keep_alive_max_count": 1,
      "keep_alive_timeout_s": 60, "max_upload_bytes": 1024, "listen": "localhost:81",
      "data_dir": "x", "web_root": "", "demo_data": true, "modbus_config": ""})")});
  EXPECT_EQ(f.threads, 3);
  EXPECT_EQ(f.queue_limit, 1u);
  EXPECT_EQ(f.read_timeout_s, 1);
  EXPECT_EQ(f.write_timeout_s, 3600);
  EXPECT_EQ(f.keep_alive_max_count, 1);
  EXPECT_EQ(f.keep_alive_timeout_s, 60);
  EXPECT_EQ(f.max_upload_bytes, 1024u);
  EXPECT_EQ(f.port, 81);
  EXPECT_TRUE(f.demo_data);
  // Command-line options win over the file.
  EXPECT_EQ(ParseServerArgs({"--threads", "5", "--config", File(R"({"threads": 3})")}).threads, 5);
}

TEST_F(ServerConfigTest, HttpLimitsFromFileAndCommandLine) {
  const auto f = ParseServerArgs({"--config", File(R"({"io_threads": 2, "max_connections": 10,
      "backlog": 64, "max_header_bytes": 8192, "header_timeout_s": 3})")});
  EXPECT_EQ(f.io_threads, 2);
  EXPECT_EQ(f.max_connections, 10u);
  EXPECT_EQ(f.backlog, 64);
  EXPECT_EQ(f.max_header_bytes, 8192u);
  EXPECT_EQ(f.header_timeout_s, 3);
  const auto c = ParseServerArgs({"--max-connections", "5", "--header-timeout-s", "7",
                                  "--queue-limit", "9", "--keep-alive-timeout-s", "2"});
  EXPECT_EQ(c.max_connections, 5u);
  EXPECT_EQ(c.header_timeout_s, 7);
  EXPECT_EQ(c.queue_limit, 9u);
  EXPECT_EQ(c.keep_alive_timeout_s, 2);
  for (const auto& [flag, v] :
       std::vector<std::pair<std::string, std::string>>{{"--max-connections", "0"},
                                                        {"--io-threads", "65"},
                                                        {"--backlog", "-1"},
                                                        {"--max-header-bytes", "100"},
                                                        {"--header-timeout-s", "0"}}) {
    SCOPED_TRACE(flag + " " + v);
    ExpectRefused({flag, v}, flag);
  }
  ExpectRefused({"--max_connections", "5"}, "--max_connections");  // options use '-'
}

TEST_F(ServerConfigTest, UploadLimitsPerFormat) {
  const auto c = ParseServerArgs({"--config", File(R"({"upload_limits":
      {"kinemetric-dbb/1": {"max_rows": 1000, "max_line_bytes": 200}},
      "max_calibration_tests": 20})")});
  std::map<std::string, ingest::TextLimits> limits;
  limits["kinemetric-dbb/1"].max_columns = 7;
  ApplyUploadLimits(c, limits);
  EXPECT_EQ(limits["kinemetric-dbb/1"].max_rows, 1000u);
  EXPECT_EQ(limits["kinemetric-dbb/1"].max_line_bytes, 200u);
  EXPECT_EQ(limits["kinemetric-dbb/1"].max_columns, 7u);  // not given: kept
  EXPECT_EQ(c.max_calibration_tests, 20u);
  // Every file format is named as the table names it, a versionless one too.
  const auto csv =
      ParseServerArgs({"--config", File(R"({"upload_limits": {"dbb-csv": {"max_rows": 50}}})")});
  ApplyUploadLimits(csv, limits);
  EXPECT_EQ(limits["dbb-csv"].max_rows, 50u);
  for (const char* bad : {R"({"upload_limits": 5})", R"({"upload_limits": {"dbb": {}}})",
                          R"({"upload_limits": {"kinemetric-dbb/9": {"max_rows": 5}}})",
                          R"({"upload_limits": {"dbb-csv": 5}})",
                          R"({"upload_limits": {"kinemetric-dbb/1": {"max_rowz": 5}}})",
                          R"({"upload_limits": {"kinemetric-dbb/1": {"max_rows": 0}}})",
                          R"({"upload_limits": {"kinemetric-dbb/1": {"max_rows": -5}}})"}) {
    SCOPED_TRACE(bad);
    EXPECT_THROW(ParseServerArgs({"--config", File(bad)}), InvalidInput);
  }
}

TEST_F(ServerConfigTest, RefusesOutOfRangeAndNonIntegerOptions) {
  for (const char* v :
       {"0", "-1", "257", "8abc", "abc", "", "1e3", "2.5", " 8", "+8", "99999999999999999999"}) {
    SCOPED_TRACE(v);
    ExpectRefused({"--threads", v}, "--threads");
  }
  for (const char* v : {"0", "-1", "4294967297", "18446744073709551615", "1k", "0x10", "1.5"}) {
    SCOPED_TRACE(v);
    ExpectRefused({"--max-upload-bytes", v}, "--max-upload-bytes");
  }
  ExpectRefused({"--threads"}, "--threads");
  ExpectRefused({"--data-dir", ""}, "--data-dir");
  for (const char* v : {"host:", "host:-1", "host:65536", "host:80x", "host: 80", ":80", "80"}) {
    SCOPED_TRACE(v);
    ExpectRefused({"--listen", v}, "--listen");
  }
}

TEST_F(ServerConfigTest, RefusesOutOfRangeAndNonIntegerConfigKeys) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> bad = {
      {"threads", {"0", "257", "-3", "2.5", "\"8\"", "1e9", "true", "null"}},
      {"queue_limit", {"0", "-1", "1.5", "\"64\"", "18446744073709551615"}},
      {"read_timeout_s", {"0", "-1", "3601", "2.5"}},
      {"write_timeout_s", {"0", "3601", "1e10"}},
      {"keep_alive_timeout_s", {"0", "3601", "-5"}},
      {"keep_alive_max_count", {"0", "-1", "0.5"}},
      {"max_upload_bytes", {"0", "-1", "4294967297", "1e300", "\"1\""}},
      {"listen", {"\"host:99999\"", "8080"}},
      {"data_dir", {"\"\"", "1"}},
      {"demo_data", {"\"yes\""}},
  };
  for (const auto& [key, values] : bad) {
    for (const auto& v : values) {
      SCOPED_TRACE(key + " = " + v);
      const std::string path = File("{\"" + key + "\": " + v + "}");
      ExpectRefused({"--config", path}, key, path);
    }
  }
  // Whole numbers written with a fraction of zero are whole numbers.
  EXPECT_EQ(ParseServerArgs({"--config", File(R"({"threads": 4.0})")}).threads, 4);
  const std::string typo = File(R"({"thread": 4})");
  ExpectRefused({"--config", typo}, "thread", typo);
}

}  // namespace
}  // namespace km::server

namespace km::server {
namespace {

// The operations options (docs/operations.md): the access log, a public /metrics, the bound of
// a graceful stop; the config file may carry // comments (deploy/kinemetricd.example.conf).
TEST_F(ServerConfigTest, OperationsOptions) {
  const auto d = ParseServerArgs({});
  EXPECT_EQ(d.access_log, "-");
  EXPECT_FALSE(d.metrics_public);
  EXPECT_EQ(d.shutdown_timeout_s, 10);
  const auto c =
      ParseServerArgs({"--access-log", "off", "--metrics-public", "--shutdown-timeout-s", "3600"});
  EXPECT_EQ(c.access_log, "off");
  EXPECT_TRUE(c.metrics_public);
  EXPECT_EQ(c.shutdown_timeout_s, 3600);
  ExpectRefused({"--shutdown-timeout-s", "0"}, "--shutdown-timeout-s");
  ExpectRefused({"--access-log"}, "--access-log");

  const auto f = ParseServerArgs({"--config", File("// the operations keys\n{\n"
                                                   "  // a file\n"
                                                   "  \"access_log\": \"/var/log/km.log\",\n"
                                                   "  \"metrics_public\": true,\n"
                                                   "  \"shutdown_timeout_s\": 30\n}\n")});
  EXPECT_EQ(f.access_log, "/var/log/km.log");
  EXPECT_TRUE(f.metrics_public);
  EXPECT_EQ(f.shutdown_timeout_s, 30);
  const std::string bad = File(R"({"metrics_public": "yes"})");
  ExpectRefused({"--config", bad}, "metrics_public", bad);
}

TEST_F(ServerConfigTest, TheDatabaseIsSqliteByDefaultOrAPostgreSqlUrl) {
  EXPECT_EQ(ParseServerArgs({}).database, "");
  EXPECT_EQ(ParseServerArgs({}).db_pool_size, 8);
  EXPECT_EQ(ParseServerArgs({"--database", "sqlite:"}).database, "sqlite:");
  const auto pg = ParseServerArgs(
      {"--database", "postgresql://km:pw@db.example:5432/kinemetric", "--db-pool-size", "32"});
  EXPECT_EQ(pg.database, "postgresql://km:pw@db.example:5432/kinemetric");
  EXPECT_EQ(pg.db_pool_size, 32);
  EXPECT_EQ(ParseServerArgs({"--database", "postgres://h/db"}).database, "postgres://h/db");
  const auto f = ParseServerArgs({"--config", File(R"({"database": "postgresql://h/km",
      "db_pool_size": 1})")});
  EXPECT_EQ(f.database, "postgresql://h/km");
  EXPECT_EQ(f.db_pool_size, 1);
  ExpectRefused({"--database", "mysql://h/db"}, "--database");
  ExpectRefused({"--database", "kinemetric.db"}, "--database");
  ExpectRefused({"--db-pool-size", "0"}, "--db-pool-size");
  ExpectRefused({"--db-pool-size", "1001"}, "--db-pool-size");
  EXPECT_EQ(ParseServerArgs({}).db_statement_timeout_ms, 0);
  EXPECT_EQ(ParseServerArgs({"--db-statement-timeout-ms", "30000"}).db_statement_timeout_ms, 30000);
  EXPECT_EQ(ParseServerArgs({"--config", File(R"({"db_statement_timeout_ms": 250})")})
                .db_statement_timeout_ms,
            250);
  ExpectRefused({"--db-statement-timeout-ms", "-1"}, "--db-statement-timeout-ms");
  ExpectRefused({"--db-statement-timeout-ms", "3600001"}, "--db-statement-timeout-ms");
  const std::string file = File(R"({"database": "sqlite:/tmp/x.db"})");
  ExpectRefused({"--config", file}, "database", file);
  // A refused URL's password is not repeated.
  try {
    ParseServerArgs({"--database", "mysql://u:hunter2@h/db"});
    ADD_FAILURE() << "accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(std::string(e.what()).find("hunter2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("mysql://u:***@h/db"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace km::server
