// Uncertainty of a tracker self-calibration from u_ranging_um (docs/methods.md §16.5): the
// Monte Carlo of M = 500 warm-started re-solves on 4³ = 64 and 10³ = 1 000 points × 4 trackers
// (0.2 µm noise, u_ranging_um 0.5 µm). The cost of one draw is the time / 500.
#include <benchmark/benchmark.h>

#include <cmath>

#include "analysis/tracker/selfcal_uncertainty.h"
#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_sim.h"

namespace km::tracker {
namespace {

TrackerSimResult MakeUncertaintySurvey(int points) {
  const Eigen::Vector3d centre(300, 200, 250);
  const int per = static_cast<int>(std::lround(std::cbrt(points)));
  TrackerSimOptions o;
  o.seed = 7;
  o.commanded_mm = GridPoints(centre, 400.0, per);
  o.trackers_mm = PlaceTrackers(centre, 4, 600, 1200, 7);
  o.machine.centre_mm = centre;
  o.machine.half_range_mm = Eigen::Vector3d::Constant(200);
  o.machine.scale_ppm = {20, -10, 15};
  o.noise_um = 0.2;
  return SimulateTrackerSurvey(o);
}

void BM_RangingUncertainty(benchmark::State& state) {
  const auto sim = MakeUncertaintySurvey(static_cast<int>(state.range(0)));
  SelfCalSolution solution;
  const SelfCalResult r = SelfCalibrate(sim.readings, {}, &solution);
  RangingUncertaintyOptions o;
  for (auto _ : state) {
    const auto u = PropagateRangingUncertainty(sim.readings, r, solution, 0.5, o);
    benchmark::DoNotOptimize(u.mc.outputs[0].u);
  }
  state.counters["draws"] = static_cast<double>(o.draws);
  state.counters["points"] = static_cast<double>(sim.readings.NumPoints());
}
BENCHMARK(BM_RangingUncertainty)->Arg(64)->Arg(1000)->Unit(benchmark::kMillisecond)->Iterations(2);

}  // namespace
}  // namespace km::tracker

BENCHMARK_MAIN();
