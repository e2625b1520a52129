// Servo-load analyses (analysis/servo). Target: the identification of a hexapod's
// masses and friction from 30 circles × 720 samples in under 1 s. Also the CW/CCW joint
// resistance of the same data and the external force of one circle. Feed drives: the friction
// of strokes at 10, 20 and 40 mm/s in one record of ~40 800 samples (2 ms) in under 1 s, and
// the parsing of that record (with its check for position jumps) in under 0.1 s.
#include <cstdint>
#include <random>
#include <string>

#include <benchmark/benchmark.h>

#include "analysis/servo/external_force.h"
#include "analysis/servo/feed_drive.h"
#include "analysis/servo/identify.h"
#include "analysis/servo/joint_resistance.h"
#include "ingest/servo_parser.h"
#include "tests/unit/servo/feed_truth.h"
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

const std::string& FeedDriveText() {
  static const std::string text = [] {
    namespace ft = km::servo::feed_truth;
    ft::Motion m = ft::BackAndForth(200.0, {10.0, 20.0, 40.0});
    m.accel_mm_s2 = 300.0;
    m.dwell_s = 1.6;
    return ft::ServoText(ft::Simulate(ft::Drive{}, m, 1));
  }();
  return text;
}

void BM_FeedDriveThreeFeeds40k(benchmark::State& state) {
  const ServoFile f = km::ingest::ParseServoFile(FeedDriveText(), "x.txt");
  for (auto _ : state) benchmark::DoNotOptimize(AnalyzeFeedDrive({&f}, "X"));
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(f.t_s.size()));
}
BENCHMARK(BM_FeedDriveThreeFeeds40k)->Unit(benchmark::kMillisecond);

void BM_ParseFeedDrive40k(benchmark::State& state) {
  const std::string& text = FeedDriveText();
  for (auto _ : state) benchmark::DoNotOptimize(km::ingest::ParseServoFile(text, "x.txt"));
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(text.size()));
}
BENCHMARK(BM_ParseFeedDrive40k)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
