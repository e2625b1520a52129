// Target: stream ingest into storage ≥ 1 000 000 samples/s.
//  * BM_StreamIngestToStorage: binary frames decoded, checked for gaps/duplicates, chunked and
//    written to the SQLite file (WAL, synchronous=FULL) — the server's path without the socket.
//  * BM_HttpStreamIngest: the same through a real HTTP server on loopback (one request a
//    second of 4 channels × 20 kHz … ×5, answered after the samples are stored).
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <thread>

#include "ingest/stream/stream_frames.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "server/streams/streams.h"
#include "tests/bench/bench_server.h"

// After the project headers: they bring in Eigen, which must come before httplib.h.
#include <httplib.h>

namespace {

namespace fs = std::filesystem;

// `channels` × `frames` binary frames of `per_frame` samples, counters continuing from `first`.
std::string Frames(int channels, std::size_t frames, std::size_t per_frame, std::uint64_t first) {
  std::string out;
  for (std::size_t f = 0; f < frames; ++f) {
    for (int c = 1; c <= channels; ++c) {
      km::ingest::SampleRun r;
      r.channel = static_cast<std::uint32_t>(c);
      r.first_counter = first + f * per_frame;
      for (std::size_t i = 0; i < per_frame; ++i) {
        const auto k = r.first_counter + i;
        r.t_us.push_back(1'763'700'000'000'000 + static_cast<std::int64_t>(k) * 50);
        r.value_um.push_back(0.3 * std::sin(1e-3 * static_cast<double>(k) + c));
        r.status.push_back(0);
      }
      out += km::ingest::EncodeBinaryFrame(r, false, false, 50'000);
    }
  }
  return out;
}

fs::path TempDir(const char* tag) {
  const fs::path dir = fs::temp_directory_path() /
                       (std::string("km-bench-") + tag + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void BM_StreamIngestToStorage(benchmark::State& state) {
  const fs::path dir = TempDir("streams");
  {
    km::server::SqliteStorage storage((dir / "k.db").string());
    km::server::StreamHub hub(storage, {});
    const auto id = hub.Create({"bench", "", "http", "{}"});
    constexpr int kChannels = 4;
    constexpr std::size_t kPerFrame = 1000, kFrames = 64;
    std::uint64_t next = 0;
    std::int64_t samples = 0;
    for (auto _ : state) {
      state.PauseTiming();
      const std::string body = Frames(kChannels, kFrames, kPerFrame, next);
      next += kFrames * kPerFrame;
      state.ResumeTiming();
      km::ingest::StreamFrameDecoder dec(km::ingest::FrameFormat::kBinary, "bench");
      km::server::IngestCounts counts;
      dec.Feed(body, [&](km::ingest::SampleRun&& r) { hub.Accept(id, std::move(r), counts); });
      dec.Finish();
      hub.Flush(id);
      samples += static_cast<std::int64_t>(counts.accepted);
    }
    state.SetItemsProcessed(samples);
  }
  fs::remove_all(dir);
}
BENCHMARK(BM_StreamIngestToStorage)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_HttpStreamIngest(benchmark::State& state) {
  const fs::path dir = TempDir("http-streams");
  {
    km::bench::BenchServer server(dir / "k.db");
    const int port = server.port();
    httplib::Client c("127.0.0.1", port);
    c.set_read_timeout(60, 0);
    c.set_default_headers({{"Authorization", "Bearer bench"}});
    const auto id = server.service().streams().CreateStream({{"machine_id", "bench"}});
    const std::string path = "/api/v1/streams/" + to_string(id) + "/frames";
    constexpr std::size_t kPerFrame = 1000, kFrames = 100;  // 4 × 100 000 samples a request
    std::uint64_t next = 0;
    std::int64_t samples = 0;
    for (auto _ : state) {
      state.PauseTiming();
      const std::string body = Frames(4, kFrames, kPerFrame, next);
      next += kFrames * kPerFrame;
      state.ResumeTiming();
      auto r = c.Post(path.c_str(), body, "application/vnd.kinemetric.stream-frame");
      if (!r || r->status != 200) {
        state.SkipWithError("stream request failed");
        break;
      }
      samples += 4 * static_cast<std::int64_t>(kFrames * kPerFrame);
    }
    state.SetItemsProcessed(samples);
  }
  fs::remove_all(dir);
}
BENCHMARK(BM_HttpStreamIngest)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
