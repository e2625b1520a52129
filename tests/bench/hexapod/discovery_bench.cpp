// Hexapod model-gap discovery target: 15 tests × 2 directions × 720 samples with hidden gravity
// deflection and joint friction, every candidate form of the registry tried at every step
// (gravity in 3 forms, friction in 3 ramp lengths with and without t1, tool length, drift in 2
// forms, servo lag): ≤ 5 s on 2 cores.
#include <benchmark/benchmark.h>

#include "analysis/discovery/hexapod_family.h"
#include "tests/unit/hexapod/effects_fixture.h"

namespace km::discovery {
namespace {

void BM_HexapodDiscovery(benchmark::State& state) {
  const auto s = hexapod::test::Simulate(
      {{"gravity_deflection", {{0, 1.52e-5}}}, {"joint_friction", {{0, 8.88}, {1, 2.0}}}}, true,
      720);
  std::size_t steps = 0;
  for (auto _ : state) {
    const auto data = hexapod::PrepareEffectFit(s.nominal, &s.phys, s.tests, s.starts,
                                                hexapod::CalibrationMethod::kAbsolute, 0);
    HexapodFamily family(data, {});
    const auto r = RunDiscovery(family, HexapodEngineOptions());
    steps = r.steps.size();
    benchmark::DoNotOptimize(r.unexplained_rms_um);
  }
  state.counters["steps"] = static_cast<double>(steps);
}
BENCHMARK(BM_HexapodDiscovery)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace km::discovery

BENCHMARK_MAIN();
