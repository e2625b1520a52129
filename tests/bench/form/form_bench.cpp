// Form analysis throughput. Targets: minimum-zone flatness of 10 000 points < 50 ms;
// straightness of 10 000 points reported.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "analysis/form/flatness.h"
#include "analysis/form/straightness.h"
#include "analysis/geometry/line_fit.h"
#include "analysis/geometry/plane_fit.h"

namespace {

km::form::Grid MakeGrid(int side, bool scattered) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.5);
  std::uniform_real_distribution<double> u(-190.0, 190.0);
  km::form::Grid g;
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) {
      const double x = scattered ? u(rng) : -190.0 + 380.0 * i / (side - 1);
      const double y = scattered ? u(rng) : -190.0 + 380.0 * j / (side - 1);
      g.x_mm.push_back(x);
      g.y_mm.push_back(y);
      g.z_um.push_back(0.1 * x - 0.05 * y + 3.0 * std::cos(x / 70.0) * std::sin(y / 50.0) +
                       noise(rng));
    }
  }
  return g;
}

km::form::Profile MakeProfile(int n) {
  std::mt19937 rng(8);
  std::normal_distribution<double> noise(0.0, 0.02);
  km::form::Profile p;
  for (int i = 0; i < n; ++i) {
    const double x = 500.0 * i / (n - 1);
    p.position_mm.push_back(x);
    p.deviation_um.push_back(0.05 * x + 0.2 * std::cos(2 * M_PI * x / 55.0) +
                             0.1 * std::sin(2 * M_PI * x / 10.0) + noise(rng));
  }
  return p;
}

void BM_MinimumZoneFlatness(benchmark::State& state) {
  const auto g = MakeGrid(static_cast<int>(state.range(0)), state.range(1) != 0);
  int pivots = 0;
  for (auto _ : state) {
    const auto z = km::geometry::FitPlaneMinimumZone(g.x_mm, g.y_mm, g.z_um);
    pivots = z.iterations;
    benchmark::DoNotOptimize(z.width);
  }
  state.counters["points"] = static_cast<double>(g.x_mm.size());
  state.counters["pivots"] = pivots;
}
// side x side points; second argument 1 = scattered positions instead of a grid.
BENCHMARK(BM_MinimumZoneFlatness)
    ->Args({100, 0})
    ->Args({100, 1})
    ->Args({30, 0})
    ->Unit(benchmark::kMillisecond);

void BM_AnalyzeFlatness(benchmark::State& state) {
  const auto g = MakeGrid(100, false);
  for (auto _ : state) benchmark::DoNotOptimize(km::form::AnalyzeFlatness(g).flatness_min_zone_um);
}
BENCHMARK(BM_AnalyzeFlatness)->Unit(benchmark::kMillisecond);

void BM_MinimumZoneStraightness(benchmark::State& state) {
  const auto p = MakeProfile(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    benchmark::DoNotOptimize(km::geometry::FitLineMinimumZone(p.position_mm, p.deviation_um).width);
  }
}
BENCHMARK(BM_MinimumZoneStraightness)->Arg(10000)->Unit(benchmark::kMillisecond);

// Whole straightness analysis: three reference lines + periodic-component search.
void BM_AnalyzeStraightness(benchmark::State& state) {
  const auto p = MakeProfile(static_cast<int>(state.range(0)));
  km::form::StraightnessOptions o;
  o.find_periodic = state.range(1) != 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(km::form::AnalyzeStraightness(p, o).straightness_lsq_um);
  }
}
BENCHMARK(BM_AnalyzeStraightness)
    ->Args({10000, 0})
    ->Args({10000, 1})
    ->Args({1000, 1})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
