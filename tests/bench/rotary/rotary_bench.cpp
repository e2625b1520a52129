// Identification of the eight location errors of a trunnion table's rotary axes from 1 000
// R-test poses (docs/methods.md §17: exact model, Gauss–Newton, SVD rank and condition, σ).
// Target: ≤ 20 ms. The poses come from the product's own model plus noise: the benchmark times
// the solve, the tests (tests/unit/rotary) judge it against the independent simulator.
#include <benchmark/benchmark.h>

#include <random>

#include "analysis/core/angles.h"
#include "analysis/rotary/rotary_identify.h"
#include "analysis/rotary/rotary_model.h"

namespace {

km::rotary::RotaryTest BenchTest(km::rotary::Kinematics k, int poses) {
  km::rotary::RotaryTest t;
  t.setup.kinematics = k;
  t.setup.tilt_axis_mm = {{8.25, 61.4}};
  t.setup.c_axis_mm = {{1.7, -2.35}};
  t.setup.sphere_mm = {{148.6, 23.9, 118.2}};
  const km::rotary::LocationErrors truth{{13.7, -8.4, -23.1, 17.6, -11.3, 7.9, 19.4, -14.2}};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> tilt(-110.0, 110.0), c(-360.0, 360.0);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (int i = 0; i < poses; ++i) {
    km::rotary::RotaryPose p;
    if (i > 0) {
      p.tilt_deg = tilt(rng);
      p.c_deg = c(rng);
    }
    const auto d = km::rotary::PredictedDisplacement(t.setup, truth, p.tilt_deg * km::kDeg,
                                                     p.c_deg * km::kDeg);
    for (int k = 0; k < 3; ++k) p.d_um[std::size_t(k)] = d(k) + (i > 0 ? noise(rng) : 0.0);
    t.poses.push_back(p);
  }
  return t;
}

void BM_IdentifyLocationErrors(benchmark::State& state) {
  const auto k = state.range(0) == 0 ? km::rotary::Kinematics::kAcTrunnion
                                     : km::rotary::Kinematics::kBcTrunnion;
  const auto test = BenchTest(k, 1000);
  for (auto _ : state) {
    auto r = km::rotary::IdentifyLocationErrors(test);
    benchmark::DoNotOptimize(r);
  }
  state.counters["poses"] = double(test.poses.size());
}
BENCHMARK(BM_IdentifyLocationErrors)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
