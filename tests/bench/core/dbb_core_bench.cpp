// Target: analysis of one 3600-sample DBB trace < 1 ms; parsing a file of that size.
#include <benchmark/benchmark.h>

#include <cmath>

#include "analysis/dbb/circular_test.h"
#include "ingest/dbb_parser.h"
#include "ingest/dbb_writer.h"
#include "tests/unit/dbb_core/dbb_synth.h"

namespace {

km::dbb::DbbTest Trace() {
  km::test::SynthOptions o;
  o.centre_err_um[0] = 5;
  o.form_um = [](double th) { return 2.0 * std::cos(2 * th) + 0.5 * std::sin(3 * th); };
  o.noise_um = 0.1;
  return km::test::MakeTrace(o);
}

void BM_AnalyzeCircularTest3600(benchmark::State& state) {
  const auto t = Trace();
  for (auto _ : state) benchmark::DoNotOptimize(km::dbb::AnalyzeCircularTest(t));
}
BENCHMARK(BM_AnalyzeCircularTest3600)->Unit(benchmark::kMicrosecond);

void BM_ParseDbb3600(benchmark::State& state) {
  const std::string text = km::ingest::WriteDbb(Trace());
  for (auto _ : state) benchmark::DoNotOptimize(km::ingest::ParseDbb(text, "bench.dbb"));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * text.size()));
}
BENCHMARK(BM_ParseDbb3600)->Unit(benchmark::kMicrosecond);

}  // namespace
