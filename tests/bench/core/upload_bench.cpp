// Targets: upload-to-stored-result through the HTTP API, p50 < 20 ms (BM_UploadToStoredResult);
// one page of a machine's measurement list with 100 000 measurements on it, p50 < 20 ms
// (BM_MeasurementListPage). A real server (router, SQLite file with WAL and synchronous=FULL)
// in this process, a real HTTP client on loopback; each upload iteration uploads a new
// 3600-sample file (distinct bytes) and waits for the stored id.
#include <benchmark/benchmark.h>

#include <sqlite3.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <thread>

#include "ingest/dbb_writer.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/bench/bench_server.h"
#include "tests/unit/dbb_core/dbb_synth.h"

// After the project headers: they bring in Eigen, which must come before httplib.h.
#include <httplib.h>

namespace {

void BM_UploadToStoredResult(benchmark::State& state) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("km-bench-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    km::bench::BenchServer server(dir / "k.db");
    const int port = server.port();
    httplib::Client c("127.0.0.1", port);
    c.set_default_headers({{"Authorization", "Bearer bench"}});
    km::test::SynthOptions so;
    so.noise_um = 0.1;
    auto trace = km::test::MakeTrace(so);
    std::vector<double> ms;
    int n = 0;
    for (auto _ : state) {
      state.PauseTiming();
      trace.test_id = "bench-" + std::to_string(n++);
      const std::string body = km::ingest::WriteDbb(trace);
      state.ResumeTiming();
      const auto t0 = std::chrono::steady_clock::now();
      auto r = c.Post("/api/v1/measurements", body, "text/plain");
      const auto t1 = std::chrono::steady_clock::now();
      if (!r || r->status != 201) {
        state.SkipWithError("upload failed");
        break;
      }
      ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    }
    if (!ms.empty()) {
      std::sort(ms.begin(), ms.end());
      state.counters["p50_ms"] = ms[ms.size() / 2];
      state.counters["p95_ms"] = ms[std::min(ms.size() - 1, ms.size() * 95 / 100)];
    }
  }
  fs::remove_all(dir);
}
BENCHMARK(BM_UploadToStoredResult)->Unit(benchmark::kMillisecond)->UseRealTime();

// Target: one page of a machine's measurement list (GET /api/v1/measurements?machine_id=…, 50
// items with their key results) under 20 ms with 100 000 measurements on that machine, newest
// first, deep in the list, by kind and by free text. The database is filled directly (one
// transaction, the rows the service itself writes, each with 4 KB of raw file and samples as a
// small DBB upload has) and then served by the real service and router in this process; the
// page is asked for as the dashboard asks for it.
void BM_MeasurementListPage(benchmark::State& state) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("km-bench-list-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  constexpr int kRows = 100'000;
  { km::server::SqliteStorage create((dir / "k.db").string()); }  // the schema
  {
    sqlite3* db = nullptr;
    sqlite3_open((dir / "k.db").string().c_str(), &db);
    sqlite3_exec(db, "BEGIN", nullptr, nullptr, nullptr);
    sqlite3_stmt* m = nullptr;
    sqlite3_stmt* r = nullptr;
    sqlite3_prepare_v2(db,
                       "INSERT INTO measurements (id, sha256, kind, format, machine_id, test_id, "
                       "direction, measured_at, uploaded_at, filename, sample_count, "
                       "metadata_json, raw, samples) VALUES (?, ?, ?, 'kinemetric-dbb/1', "
                       "'vmc-1', ?, ?, ?, ?, ?, 720, '{}', zeroblob(3000), zeroblob(1000))",
                       -1, &m, nullptr);
    sqlite3_prepare_v2(db,
                       "INSERT INTO results (measurement_id, analysis, analysis_version, "
                       "input_sha256, created_at, result_json) VALUES (?, ?, 'v', ?, "
                       "'2026-01-01T00:00:00Z', ?)",
                       -1, &r, nullptr);
    for (int i = 1; i <= kRows; ++i) {
      const std::string sha = "sha" + std::to_string(i);
      const bool dbb = i % 10 != 0;
      const std::string kind = dbb ? "dbb" : "straightness";
      // Six years of tests, the newest last: year, month, day and time from the index.
      char measured[32];
      std::snprintf(measured, sizeof measured, "%04d-%02d-%02dT%02d:%02d:%02dZ", 2020 + i / 20'000,
                    1 + (i / 1'700) % 12, 1 + (i / 60) % 28, (i / 3) % 24, i % 60, (7 * i) % 60);
      const std::string name = "run" + std::to_string(i) + (i % 2 ? "_cw.txt" : "_ccw.txt");
      sqlite3_bind_int64(m, 1, i);
      sqlite3_bind_text(m, 2, sha.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(m, 3, kind.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(m, 4, ("t" + std::to_string(i % 40)).c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(m, 5, i % 2 ? "cw" : "ccw", -1, SQLITE_STATIC);
      sqlite3_bind_text(m, 6, measured, -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(m, 7, measured, -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(m, 8, name.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_step(m);
      sqlite3_reset(m);
      // A result of the size the service stores for a DBB test (a few KiB of JSON).
      const std::string json = std::string("{\"") +
                               (dbb ? "circularity_um" : "straightness_min_zone_um") +
                               "\":" + std::to_string(1.0 + i % 97 * 0.01) + ",\"harmonics\":[" +
                               std::string(3000, ' ') + "]}";
      sqlite3_bind_int64(r, 1, i);
      sqlite3_bind_text(r, 2, kind.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(r, 3, sha.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(r, 4, json.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_step(r);
      sqlite3_reset(r);
    }
    sqlite3_finalize(m);
    sqlite3_finalize(r);
    sqlite3_exec(db, "COMMIT", nullptr, nullptr, nullptr);
    sqlite3_close(db);
  }
  const std::map<std::string, std::string> queries = {
      {"newest", "order=newest&limit=50"},
      {"deep", "order=newest&limit=50&offset=50000"},
      {"uploaded", "order=uploaded&limit=50"},
      {"kind", "order=newest&limit=50&kind=straightness"},
      {"text", "order=newest&limit=50&q=run99999"},
      {"test_dates",
       "order=newest&limit=50&test_id=t7&from=2022-01-01T00:00:00Z&to=2023-01-01T00:00:00Z"},
  };
  {
    km::bench::BenchServer server(dir / "k.db");
    httplib::Client c("127.0.0.1", server.port());
    c.set_default_headers({{"Authorization", "Bearer bench"}});
    std::map<std::string, std::vector<double>> ms;
    for (auto _ : state) {
      for (const auto& [name, query] : queries) {
        const auto t0 = std::chrono::steady_clock::now();
        auto res = c.Get("/api/v1/measurements?machine_id=vmc-1&" + query);
        const auto t1 = std::chrono::steady_clock::now();
        if (!res || res->status != 200 || res->body.find("\"key_result\"") == std::string::npos) {
          state.SkipWithError(("list failed: " + name).c_str());
          break;
        }
        ms[name].push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      }
    }
    for (auto& [name, v] : ms) {
      std::sort(v.begin(), v.end());
      state.counters[name + "_p50_ms"] = v[v.size() / 2];
    }
  }
  fs::remove_all(dir);
}
BENCHMARK(BM_MeasurementListPage)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(20);

}  // namespace

BENCHMARK_MAIN();
