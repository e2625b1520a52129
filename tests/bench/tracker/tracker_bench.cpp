// Self-calibration throughput: m points × 4 trackers (targets: 1 000 points < 0.05 s,
// 10 000 points — BM_SelfCal/10000/0, 10 648 points — ≤ 0.4 s), with 0.2 µm noise, the full
// pipeline (initialisation, least squares of [Tracker paper] eq. 1, robust pass and rejection
// rounds when readings stand out, covariance, best fit, spatial check) and the geometric
// decomposition.
#include <benchmark/benchmark.h>

#include <cmath>

#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_sim.h"
#include "analysis/tracker/volumetric_decomposition.h"

namespace km::tracker {
namespace {

TrackerSimResult MakeSurvey(int points, double outliers) {
  const Eigen::Vector3d centre(300, 200, 250);
  const int per = static_cast<int>(std::lround(std::cbrt(points)));
  TrackerSimOptions o;
  o.seed = 7;
  o.commanded_mm = GridPoints(centre, 400.0, per);
  o.trackers_mm = PlaceTrackers(centre, 4, 600, 1200, 7);
  o.machine.centre_mm = centre;
  o.machine.half_range_mm = Eigen::Vector3d::Constant(200);
  o.machine.scale_ppm = {20, -10, 15};
  o.machine.squareness_um_per_m = {20, -15, 10};
  o.noise_um = 0.2;
  o.outlier_fraction = outliers;
  return SimulateTrackerSurvey(o);
}

void BM_SelfCal(benchmark::State& state) {
  const auto sim = MakeSurvey(static_cast<int>(state.range(0)), state.range(1) / 100.0);
  for (auto _ : state) {
    const auto r = SelfCalibrate(sim.readings);
    benchmark::DoNotOptimize(r.residual_rms_um);
    state.counters["rejected"] = static_cast<double>(r.rejected.size());
    state.counters["iterations"] = r.iterations;
  }
  state.counters["points"] = static_cast<double>(sim.readings.NumPoints());
}
// {points, outlier %}: 10³ = 1 000 and 22³ = 10 648 points.
BENCHMARK(BM_SelfCal)
    ->Args({1000, 0})
    ->Args({1000, 2})
    ->Args({10000, 0})
    ->Args({10000, 2})
    ->Unit(benchmark::kMillisecond);

void BM_Decomposition(benchmark::State& state) {
  const auto sim = MakeSurvey(static_cast<int>(state.range(0)), 0.0);
  const auto r = SelfCalibrate(sim.readings);
  for (auto _ : state) {
    const auto d = DecomposeVolumetricError(sim.readings.commanded_mm, r.volumetric_error_um);
    benchmark::DoNotOptimize(d.residual_rms_um);
  }
}
BENCHMARK(BM_Decomposition)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace km::tracker

BENCHMARK_MAIN();
