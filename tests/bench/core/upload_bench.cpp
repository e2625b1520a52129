// Target: upload-to-stored-result through the HTTP API, p50 < 20 ms. A real server (router,
// SQLite file with WAL and synchronous=FULL) in this process, a real HTTP client on loopback;
// each iteration uploads a new 3600-sample file (distinct bytes) and waits for the stored id.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <thread>

#include "ingest/dbb_writer.h"
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

}  // namespace

BENCHMARK_MAIN();
