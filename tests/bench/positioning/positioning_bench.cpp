// Laser positioning throughput. Target: 10 000 readings (50 targets × 100 runs × 2 directions)
// analysed (ISO 230-2 and VDI 3441 figures, compensation table) in ≤ 5 ms; the whole file
// (parse, corrections with the refractive index, analysis, JSON) reported.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "analysis/positioning/compensation.h"
#include "analysis/positioning/figures.h"
#include "ingest/positioning_parser.h"
#include "tests/unit/positioning/positioning_sim.h"
#include "usecases/positioning_report.h"

namespace {

km::positioning::test::Truth BenchTruth() {
  km::positioning::test::Truth t;
  t.runs = 100;
  for (int i = 0; i < 50; ++i) t.targets_mm.push_back(20.0 * i);
  t.raw = true;
  t.refractive_index = 1.00027;
  t.deviation_column = false;
  return t;
}

void BM_AnalyseReadings(benchmark::State& state) {
  const auto file = km::ingest::ParsePositioningFile(
      km::positioning::test::SimulateFile(BenchTruth()), "bench.txt");
  for (auto _ : state) {
    auto f = km::positioning::EvaluatePositioning(file.readings);
    auto c = km::positioning::MakeCompensation(f.targets);
    benchmark::DoNotOptimize(c);
  }
  state.counters["readings"] = double(file.readings.size());
}
BENCHMARK(BM_AnalyseReadings)->Unit(benchmark::kMillisecond);

void BM_WholeFile(benchmark::State& state) {
  const std::string text = km::positioning::test::SimulateFile(BenchTruth());
  for (auto _ : state) {
    auto r = km::usecases::AnalysePositioning(km::ingest::ParsePositioningFile(text, "bench.txt"));
    auto j = km::usecases::PositioningReportToJson(r);
    benchmark::DoNotOptimize(j);
  }
}
BENCHMARK(BM_WholeFile)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
