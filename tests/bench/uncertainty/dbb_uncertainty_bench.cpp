// The uncertainty of a DBB pair's figures by Monte Carlo ([JCGM 101], analysis/dbb/
// dbb_uncertainty.h): a cw + ccw pair of 3 600 readings each (R 150 mm, a 7.3 µm oval and a
// 2.1 µm third harmonic, 0.1 µm of machine scatter), u_reading_um 0.37, u_bar_length_um 0.9,
// u_bar_temperature_c 0.3 with α 11.2 ppm/K; M = 1000 draws of the ten figures (both tests'
// four, H and G(b)). Target: ≤ 30 ms on one core (the analysis itself, AnalyzeDbbSet, not
// counted: its figures are the propagation's starting point). Arguments: budget by one input
// at a time (200 draws per input) on/off, the first-order GUM check on/off.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <random>

#include "analysis/dbb/dbb_uncertainty.h"
#include "analysis/dbb/full_analysis.h"
#include "tests/bench/bench_main.h"

namespace km::dbb {
namespace {

DbbTest Trace(Direction dir, unsigned seed) {
  DbbTest t;
  t.machine_id = "bench";
  t.test_id = "xy-r150";
  t.direction = dir;
  t.bar_length_mm = 150.0;
  t.radius_mm = 150.0;
  t.feed_mm_min = 1000.0;
  std::mt19937_64 g(seed);
  std::normal_distribution<double> noise(0.0, 0.1);
  const double s = dir == Direction::kCcw ? 1.0 : -1.0;
  for (int i = 0; i < 3600; ++i) {
    const double a = s * 0.1 * i;
    const double th = a * std::numbers::pi / 180.0;
    t.angle_deg.push_back(a);
    t.dr_um.push_back(3.65 * std::cos(2.0 * th - 0.4) + 1.05 * std::cos(3.0 * th + 1.1) + noise(g));
  }
  return t;
}

void BM_DbbPairUncertainty(benchmark::State& state) {
  std::vector<DbbTest> tests;
  tests.push_back(Trace(Direction::kCw, 1));
  tests.push_back(Trace(Direction::kCcw, 2));
  DbbAnalysisOptions ao;
  ao.threads = 1;
  ao.diagnose = false;
  const DbbReport rep = AnalyzeDbbSet(tests, ao);
  DbbInputUncertainty u;
  u.reading_um = 0.37;
  u.bar_length_um = 0.9;
  u.bar_temperature_c = 0.3;
  u.expansion_ppm_per_k = 11.2;
  DbbUncertaintyOptions o;
  o.budget_draws = state.range(0) != 0 ? o.budget_draws : 0;
  o.gum_check = state.range(1) != 0;
  const auto& p = rep.pairs.at(0);
  for (auto _ : state) {
    const auto r =
        PropagateDbbPair(tests[p.cw], tests[p.ccw], rep.tests[p.cw], rep.tests[p.ccw], p, u, u, o);
    benchmark::DoNotOptimize(r.mc.outputs[8].u);
  }
}
BENCHMARK(BM_DbbPairUncertainty)
    ->Args({0, 0})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace km::dbb

KM_BENCHMARK_MAIN();
