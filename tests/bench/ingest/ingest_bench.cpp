// Parsing large measurement files, and the upload of the largest file each kind accepts by
// default (parse, analysis, storage). Counters: peak_bytes_per_input_byte (peak bytes allocated
// during one parse, counted by this binary's global operator new, divided by the file size),
// input_MB, max_rss_MB (of the whole process so far). Targets: a parse allocates at most 3× the
// file size; one upload at the default limits takes at most about 2 s of CPU.
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <string>

#include "analysis/tracker/tracker_sim.h"
#include "ingest/dbb_parser.h"
#include "ingest/form_parsers.h"
#include "ingest/text_format.h"
#include "ingest/tracker_parser.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/ingest/big_files.h"
#include "tests/unit/ingest/counting_new.h"
#include "tests/unit/tracker/tracker_test_util.h"

namespace {

double MaxRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

// Times `parse` on `text`; reports the peak allocation of one parse per input byte.
void RunParse(benchmark::State& state, const std::string& text,
              const std::function<void(const std::string&)>& parse) {
  std::size_t peak = 0;
  for (auto _ : state) {
    peak = std::max(peak, km::test::PeakOf([&] { parse(text); }));
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * text.size()));
  state.counters["input_MB"] = static_cast<double>(text.size()) / (1 << 20);
  state.counters["peak_bytes_per_input_byte"] =
      static_cast<double>(peak) / static_cast<double>(text.size());
  state.counters["max_rss_MB"] = MaxRssMb();
}

void BM_ParseDbb20MB(benchmark::State& state) {
  const std::string text = km::test::BigDbbFile(1'000'000);
  RunParse(state, text, [](const std::string& t) {
    benchmark::DoNotOptimize(km::ingest::ParseDbb(t, "big.txt"));
  });
}
BENCHMARK(BM_ParseDbb20MB)->Unit(benchmark::kMillisecond)->Iterations(3);

// 1 000 000 points (20 MB) is the most a straightness file may hold; 1 450 000 (29 MB) is
// refused.
void BM_ParseStraightness20MB(benchmark::State& state) {
  const std::string text = km::test::BigStraightnessFile(1'000'000);
  RunParse(state, text, [](const std::string& t) {
    benchmark::DoNotOptimize(km::ingest::ParseStraightnessFile(t, "big.txt"));
  });
}
BENCHMARK(BM_ParseStraightness20MB)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ParseFlatness25MB(benchmark::State& state) {
  const std::string text = km::test::BigFlatnessFile(1000);
  RunParse(state, text, [](const std::string& t) {
    benchmark::DoNotOptimize(km::ingest::ParseFlatnessFile(t, "big.txt"));
  });
}
BENCHMARK(BM_ParseFlatness25MB)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ParseTracker8MB(benchmark::State& state) {
  const std::string text = km::test::BigTrackerFile(47);
  RunParse(state, text, [](const std::string& t) {
    benchmark::DoNotOptimize(km::ingest::ParseTrackerFile(t, "big.txt"));
  });
}
BENCHMARK(BM_ParseTracker8MB)->Unit(benchmark::kMillisecond)->Iterations(3);

// The upload path's check of the limits, before any parsing: the whole of a 20 MB file (the
// default row limit, 500 000 samples, raised so that the scan reads it all).
void BM_CheckUploadLimitsDbb20MB(benchmark::State& state) {
  const std::string text = km::test::BigDbbFile(1'000'000);
  auto limits = km::server::DefaultUploadLimits().at(km::ingest::kDbbFormat);
  limits.max_rows = 1'000'000;
  RunParse(state, text,
           [&](const std::string& t) { km::ingest::CheckTextLimits(t, "big.txt", limits); });
}
BENCHMARK(BM_CheckUploadLimitsDbb20MB)->Unit(benchmark::kMillisecond)->Iterations(5);

// A whole upload (limits, parse, analysis, SQLite) of the largest file of a kind; each
// iteration sends different bytes (a header line differs).
void RunUpload(benchmark::State& state, const std::string& text) {
  namespace fs = std::filesystem;
  const fs::path db =
      fs::temp_directory_path() / ("km-ingest-bench-" + std::to_string(::getpid()) + ".db");
  for (const char* ext : {"", "-wal", "-shm"}) fs::remove(db.string() + ext);
  {
    km::server::ServiceOptions options;
    options.upload_limits = {};  // the comparison runs beyond the default limits
    km::server::Service svc(std::make_unique<km::server::SqliteStorage>(db.string()), options);
    km::server::RegisterBuiltinKinds(svc.measurements());
    const auto at = text.find('\n') + 1;  // after the format line
    int n = 0;
    for (auto _ : state) {
      state.PauseTiming();
      const std::string body =
          text.substr(0, at) + "# run: " + std::to_string(n++) + "\n" + text.substr(at);
      state.ResumeTiming();
      if (!svc.measurements().Upload(body, "big.txt").created) state.SkipWithError("not stored");
    }
    state.counters["input_MB"] = static_cast<double>(text.size()) / (1 << 20);
    state.counters["max_rss_MB"] = MaxRssMb();
  }
  for (const char* ext : {"", "-wal", "-shm"}) fs::remove(db.string() + ext);
}

// 500 000 samples is the default limit; 1 000 000 (20 MB) for comparison.
void BM_UploadDbb(benchmark::State& state) {
  RunUpload(state, km::test::BigDbbFile(static_cast<std::size_t>(state.range(0))));
}
BENCHMARK(BM_UploadDbb)->Arg(500'000)->Arg(1'000'000)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_UploadStraightness100kPoints(benchmark::State& state) {
  RunUpload(state, km::test::BigStraightnessFile(100'000));
}
BENCHMARK(BM_UploadStraightness100kPoints)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_UploadFlatness1MPoints(benchmark::State& state) {
  RunUpload(state, km::test::BigFlatnessFile(1000));
}
BENCHMARK(BM_UploadFlatness1MPoints)->Unit(benchmark::kMillisecond)->Iterations(2);

// A consistent survey of n trackers with as many points as the default limits allow (10 000
// points, 80 000 values): 21³ points for 4 trackers, 18³ for 8, 15³ for 16.
void BM_UploadTrackerSurvey(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int per_axis = n <= 4 ? 21 : n <= 8 ? 18 : 15;
  const auto o = km::tracker::test::MakeSetup(400.0, per_axis, n, 7);
  RunUpload(state, km::ingest::WriteTrackerFile(km::tracker::SimulateTrackerSurvey(o).readings));
}
BENCHMARK(BM_UploadTrackerSurvey)
    ->Arg(4)
    ->Arg(8)
    ->Arg(16)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
