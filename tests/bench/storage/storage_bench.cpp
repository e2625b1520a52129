// The storage interface on each backend, one caller: storing a measurement (an 80 kB file, 4000
// samples, one result), reading one record, a page of 50 of a machine's 1000 measurements
// (newest first), and a stored file's bytes. SQLite is a file with WAL and synchronous=FULL;
// PostgreSQL is a test cluster (fsync off) on loopback, so stores there are not durable ones and
// its figures are those of the round trips and the server's work.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include "server/storage/pg/pg_storage.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/pg_test_server.h"

namespace {

namespace fs = std::filesystem;
using km::server::NewMeasurement;
using km::server::Storage;

constexpr int kFiles = 1000;

// One benchmark's storage. A SQLite file (with its -wal and -shm companions) is removed when the
// benchmark ends: each holds about 100 MB, and runs must not fill the temporary directory.
class Backend {
 public:
  explicit Backend(const std::string& backend) {
    if (backend == "postgresql") {
      const std::string url = km::server::test::FreshDatabaseUrl();
      if (!url.empty()) storage_ = std::make_unique<km::server::PgStorage>(url);
      return;
    }
    static int n = 0;
    file_ = fs::temp_directory_path() /
            ("km-storage-bench-" + std::to_string(::getpid()) + "-" + std::to_string(++n) + ".db");
    RemoveFiles();
    storage_ = std::make_unique<km::server::SqliteStorage>(file_.string());
  }
  ~Backend() {
    storage_.reset();
    RemoveFiles();
  }
  Backend(const Backend&) = delete;
  Backend& operator=(const Backend&) = delete;

  explicit operator bool() const { return storage_ != nullptr; }
  Storage* operator->() const { return storage_.get(); }

 private:
  void RemoveFiles() const {
    if (file_.empty()) return;
    std::error_code ec;
    for (const char* suffix : {"", "-wal", "-shm", "-journal"}) {
      fs::remove(file_.string() + suffix, ec);
    }
  }

  fs::path file_;
  std::unique_ptr<Storage> storage_;
};

NewMeasurement File(int i) {
  NewMeasurement m;
  m.sha256 = "sha-" + std::to_string(i);
  m.kind = "dbb";
  m.format = "kinemetric-dbb/1";
  m.machine_id = "bench";
  m.test_id = "t" + std::to_string(i);
  m.direction = i % 2 ? "cw" : "ccw";
  m.measured_at =
      "2026-01-01T00:00:" + std::string(i % 60 < 10 ? "0" : "") + std::to_string(i % 60) + "Z";
  m.metadata_json = "{}";
  m.raw.assign(80'000, static_cast<char>('a' + i % 26));
  m.samples.columns = {"angle_deg", "dr_um"};
  m.samples.values.assign(4000, 0.5 * i);
  return m;
}

// A storage holding kFiles measurements of machine "bench".
std::unique_ptr<Backend> Filled(const std::string& backend) {
  auto s = std::make_unique<Backend>(backend);
  if (*s) {
    for (int i = 0; i < kFiles; ++i) (*s)->PutMeasurement(File(i), {{"dbb", "dbb/1", "{}"}});
  }
  return s;
}

void BM_PutMeasurement(benchmark::State& state, const std::string& backend) {
  Backend s(backend);
  if (!s) return state.SkipWithError("no PostgreSQL server");
  int i = 0;
  for (auto _ : state) s->PutMeasurement(File(i++), {{"dbb", "dbb/1", R"({"r":1})"}});
  state.SetItemsProcessed(state.iterations());
}

void BM_GetMeasurement(benchmark::State& state, const std::string& backend) {
  auto s = Filled(backend);
  if (!*s) return state.SkipWithError("no PostgreSQL server");
  std::int64_t i = 0;
  for (auto _ : state)
    benchmark::DoNotOptimize((*s)->GetMeasurement(km::server::MeasurementId(1 + i++ % kFiles)));
  state.SetItemsProcessed(state.iterations());
}

void BM_ListMeasurementsPage(benchmark::State& state, const std::string& backend) {
  auto s = Filled(backend);
  if (!*s) return state.SkipWithError("no PostgreSQL server");
  km::server::MeasurementFilter f;
  f.machine_id = "bench";
  f.order = km::server::MeasurementFilter::Order::kNewest;
  std::int64_t i = 0;
  for (auto _ : state) {
    f.offset = (i++ * 50) % kFiles;
    benchmark::DoNotOptimize((*s)->ListMeasurements(f));
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_GetRaw(benchmark::State& state, const std::string& backend) {
  auto s = Filled(backend);
  if (!*s) return state.SkipWithError("no PostgreSQL server");
  std::int64_t i = 0;
  for (auto _ : state)
    benchmark::DoNotOptimize((*s)->GetRaw(km::server::MeasurementId(1 + i++ % kFiles)));
  state.SetItemsProcessed(state.iterations());
}

}  // namespace

BENCHMARK_CAPTURE(BM_PutMeasurement, sqlite, std::string("sqlite"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_PutMeasurement, postgresql, std::string("postgresql"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_GetMeasurement, sqlite, std::string("sqlite"))->UseRealTime();
BENCHMARK_CAPTURE(BM_GetMeasurement, postgresql, std::string("postgresql"))->UseRealTime();
BENCHMARK_CAPTURE(BM_ListMeasurementsPage, sqlite, std::string("sqlite"))->UseRealTime();
BENCHMARK_CAPTURE(BM_ListMeasurementsPage, postgresql, std::string("postgresql"))->UseRealTime();
BENCHMARK_CAPTURE(BM_GetRaw, sqlite, std::string("sqlite"))->UseRealTime();
BENCHMARK_CAPTURE(BM_GetRaw, postgresql, std::string("postgresql"))->UseRealTime();

BENCHMARK_MAIN();
