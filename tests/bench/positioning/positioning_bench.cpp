// Laser positioning throughput. Target: 10 000 readings (50 targets × 100 runs × 2 directions)
// analysed (ISO 230-2 and VDI 3441 figures, compensation table) in ≤ 5 ms; the whole file
// (parse, corrections with the refractive index, analysis, JSON) reported. The uncertainty of
// every figure (docs/methods.md §16.3: the raw per-target figures, 15 000 Monte Carlo draws of
// all six inputs, a budget of 2 500 draws per input, the GUM check): target ≤ 50 ms on one core.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "analysis/positioning/compensation.h"
#include "analysis/positioning/figure_uncertainty.h"
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

void BM_AnalyzeReadings(benchmark::State& state) {
  const auto file = km::ingest::ParsePositioningFile(
      km::positioning::test::SimulateFile(BenchTruth()), "bench.txt");
  for (auto _ : state) {
    auto f = km::positioning::EvaluatePositioning(file.readings);
    auto c = km::positioning::MakeCompensation(f.targets);
    benchmark::DoNotOptimize(c);
  }
  state.counters["readings"] = double(file.readings.size());
}
BENCHMARK(BM_AnalyzeReadings)->Unit(benchmark::kMillisecond);

void BM_WholeFile(benchmark::State& state) {
  const std::string text = km::positioning::test::SimulateFile(BenchTruth());
  for (auto _ : state) {
    auto r = km::usecases::AnalyzePositioning(km::ingest::ParsePositioningFile(text, "bench.txt"));
    auto j = km::usecases::PositioningReportToJson(r);
    benchmark::DoNotOptimize(j);
  }
}
BENCHMARK(BM_WholeFile)->Unit(benchmark::kMillisecond);

// Every input stated, raw readings and a warm machine: all six inputs drawn.
std::string UncertainFile() {
  auto t = BenchTruth();
  t.warm = true;
  std::string text = km::positioning::test::SimulateFile(t);
  text.insert(text.find("run,direction"),
              "# u_laser_ppm: 0.35\n# u_air_temperature_c: 0.12\n# u_air_pressure_pa: 35\n"
              "# u_air_humidity_pct: 6\n# u_material_temperature_c: 0.15\n"
              "# u_expansion_ppm_per_k: 0.6\n");
  return text;
}

// What the uncertainty adds to the analysis of a parsed file: the per-target figures of the raw
// readings and the propagation with its budget and GUM check.
void BM_Uncertainty(benchmark::State& state) {
  const auto file = km::ingest::ParsePositioningFile(UncertainFile(), "bench.txt");
  const km::positioning::PositioningInputUncertainties u{0.35, 0.12, 35.0, 6.0, 0.15, 0.6};
  for (auto _ : state) {
    const auto raw = km::positioning::EvaluatePositioning(file.readings);
    auto r = km::positioning::PropagatePositioningUncertainty(raw.targets, file.corrections, u);
    benchmark::DoNotOptimize(r);
  }
  state.counters["readings"] = double(file.readings.size());
}
BENCHMARK(BM_Uncertainty)->Unit(benchmark::kMillisecond);

void BM_WholeFileWithUncertainty(benchmark::State& state) {
  const std::string text = UncertainFile();
  for (auto _ : state) {
    auto r = km::usecases::AnalyzePositioning(km::ingest::ParsePositioningFile(text, "bench.txt"));
    auto j = km::usecases::PositioningReportToJson(r);
    benchmark::DoNotOptimize(j);
  }
}
BENCHMARK(BM_WholeFileWithUncertainty)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
