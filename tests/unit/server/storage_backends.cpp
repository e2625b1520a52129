#include "tests/unit/server/storage_backends.h"

#include <unistd.h>

#include <filesystem>

#include "server/storage/pg/pg_storage.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/pg_test_server.h"

namespace km::server::test {

namespace fs = std::filesystem;

void Backends::SetUp() {
  if (postgres()) {
    url_ = FreshDatabaseUrl();
    if (url_.empty()) GTEST_SKIP() << "no PostgreSQL server (KINEMETRIC_TEST_DATABASE)";
    return;
  }
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string(info->test_suite_name()) + "-" + info->name();
  for (auto& c : name) c = c == '/' ? '-' : c;
  path_ = (fs::temp_directory_path() / ("km-" + std::to_string(::getpid()) + "-" + name + ".db"))
              .string();
  fs::remove(path_);
}

void Backends::TearDown() {
  if (path_.empty()) return;
  for (const char* ext : {"", "-wal", "-shm"}) fs::remove(path_ + ext);
}

std::unique_ptr<Storage> Backends::Open() {
  if (postgres()) return std::make_unique<PgStorage>(url_);
  return std::make_unique<SqliteStorage>(path_);
}

NewMeasurement Backends::Sample(const std::string& sha, const std::string& machine) {
  NewMeasurement m;
  m.sha256 = sha;
  m.kind = "dbb";
  m.format = "kinemetric-dbb/1";
  m.machine_id = machine;
  m.test_id = "t";
  m.direction = "ccw";
  m.measured_at =
      "2026-01-0" + std::to_string(1 + (static_cast<unsigned char>(sha[0]) % 8)) + "T00:00:00Z";
  m.metadata_json = "{}";
  m.raw = "raw bytes " + sha;
  m.samples.columns = {"a", "b"};
  m.samples.values = {1, 2, 3, 4, 5, 6};
  return m;
}

NewMachineModel Backends::Model(const std::string& machine, const std::string& doc) {
  return NewMachineModel{machine, "upload", "note of " + doc, doc, "sha-" + doc};
}

INSTANTIATE_TEST_SUITE_P(, Backends, ::testing::Values("sqlite", "postgresql"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

}  // namespace km::server::test
