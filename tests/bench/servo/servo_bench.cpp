// Servo-load analyses (analysis/servo). Target: the identification of a hexapod's
// masses and friction from 30 circles × 720 samples in under 1 s. Also the CW/CCW joint
// resistance of the same data and the external force of one circle.
#include <random>

#include <benchmark/benchmark.h>

#include "analysis/servo/external_force.h"
#include "analysis/servo/identify.h"
#include "analysis/servo/joint_resistance.h"
#include "tests/unit/servo/servo_fixture.h"

namespace {

using namespace km::servo;

const std::vector<ServoFile>& Plan() {
  static const std::vector<ServoFile> files =
      km::servo::test::SimulatePlan(truth::Pm600Truth(), 2.0, 720, 1);
  return files;
}

void BM_IdentifyJigPlan30x720(benchmark::State& state) {
  const auto& files = Plan();
  const auto g = km::servo::test::Pm600Geometry();
  const auto m = km::servo::test::Pm600Physics();
  for (auto _ : state) benchmark::DoNotOptimize(IdentifyLoads(g, m, files));
  state.SetItemsProcessed(state.iterations() * 30 * 720);
}
BENCHMARK(BM_IdentifyJigPlan30x720)->Unit(benchmark::kMillisecond);

void BM_JointResistance30x720(benchmark::State& state) {
  const auto& files = Plan();
  const auto g = km::servo::test::Pm600Geometry();
  const auto m = km::servo::test::Pm600Physics();
  for (auto _ : state) benchmark::DoNotOptimize(EstimateJointResistance(g, m, files));
}
BENCHMARK(BM_JointResistance30x720)->Unit(benchmark::kMillisecond);

void BM_ExternalForce720(benchmark::State& state) {
  const auto& files = Plan();
  const auto g = km::servo::test::Pm600Geometry();
  const auto m = km::servo::test::Pm600Physics();
  for (auto _ : state) benchmark::DoNotOptimize(EstimateExternalForce(g, m, files[0]));
}
BENCHMARK(BM_ExternalForce720)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
