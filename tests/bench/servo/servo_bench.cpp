// Servo-load analyses (analysis/servo). Targets (Release, one core): the work of
// `kinemetric servo identify` on the jig plan — 30 circles × 720 samples parsed from their
// text and identified — in under 0.3 s (BM_IdentifyCommand30x720; BM_IdentifyJigPlan30x720 is
// the identification alone); the work of `kinemetric servo feed-drive` on a record of ~40 800
// samples (2 ms) of strokes at 10, 20 and 40 mm/s with a short record of small oscillations
// beside it — both parsed and analysed together — in under 60 ms
// (BM_FeedDriveCommand40kWithShortRecord; BM_FeedDriveThreeFeeds40k is the long record's
// analysis alone). Also the CW/CCW joint resistance of the jig plan, the external force of one
// circle and the parsing of the long record (with its check for position jumps) in under 0.1 s.
// The identification and the feed drive run their independent parts side by side
// (km::ParallelFor): the figures are wall-clock times on the machine's cores; `taskset -c 0`
// gives those of one core.
#include <cstdint>
#include <random>
#include <string>

#include <benchmark/benchmark.h>

#include "analysis/servo/external_force.h"
#include "analysis/servo/feed_drive.h"
#include "analysis/servo/identify.h"
#include "analysis/servo/joint_resistance.h"
#include "ingest/servo_parser.h"
#include "tests/bench/bench_main.h"
#include "tests/unit/servo/feed_truth.h"
#include "tests/unit/servo/servo_fixture.h"
#include "tests/unit/servo/servo_truth.h"

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

// The jig plan as the command reads it: one `kinemetric-servo/1` text a circle.
const std::vector<std::string>& PlanTexts() {
  static const std::vector<std::string> texts = [] {
    std::vector<std::string> out;
    std::mt19937 rng(7);
    const auto m = truth::Pm600Truth();
    for (auto c : truth::JigPlan(720)) {
      for (bool ccw : {true, false}) {
        c.ccw = ccw;
        out.push_back(truth::ServoText(c, truth::Simulate(m, c, 2.0, rng)));
      }
    }
    return out;
  }();
  return texts;
}

void BM_IdentifyCommand30x720(benchmark::State& state) {
  const auto& texts = PlanTexts();
  const auto g = km::servo::test::Pm600Geometry();
  const auto m = km::servo::test::Pm600Physics();
  for (auto _ : state) {
    std::vector<ServoFile> files;
    for (const auto& t : texts) files.push_back(km::ingest::ParseServoFile(t, "plan.txt"));
    benchmark::DoNotOptimize(IdentifyLoads(g, m, files));
  }
  state.SetItemsProcessed(state.iterations() * 30 * 720);
}
BENCHMARK(BM_IdentifyCommand30x720)->Unit(benchmark::kMillisecond);

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

// A short record beside the long one: small oscillations of 3 mm at 2 and 4 mm/s (~3 000
// samples), whose slow reversals the LuGre fit sees with the long record's.
const std::string& ShortRecordText() {
  static const std::string text = [] {
    namespace ft = km::servo::feed_truth;
    ft::Motion m = ft::BackAndForth(3.0, {2.0, 4.0});
    m.accel_mm_s2 = 100.0;
    m.dwell_s = 0.3;
    return ft::ServoText(ft::Simulate(ft::Drive{}, m, 5), "x-oscillation");
  }();
  return text;
}

void BM_FeedDriveCommand40kWithShortRecord(benchmark::State& state) {
  FeedDriveText();  // the records simulated before the clock runs
  ShortRecordText();
  std::size_t samples = 0;
  for (auto _ : state) {
    const ServoFile a = km::ingest::ParseServoFile(FeedDriveText(), "x.txt");
    const ServoFile b = km::ingest::ParseServoFile(ShortRecordText(), "x-osc.txt");
    samples = a.t_s.size() + b.t_s.size();
    benchmark::DoNotOptimize(AnalyzeFeedDrive({&a, &b}, "X"));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(samples));
}
BENCHMARK(BM_FeedDriveCommand40kWithShortRecord)->Unit(benchmark::kMillisecond);

void BM_ParseFeedDrive40k(benchmark::State& state) {
  const std::string& text = FeedDriveText();
  for (auto _ : state) benchmark::DoNotOptimize(km::ingest::ParseServoFile(text, "x.txt"));
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(text.size()));
}
BENCHMARK(BM_ParseFeedDrive40k)->Unit(benchmark::kMillisecond);

}  // namespace

KM_BENCHMARK_MAIN();
