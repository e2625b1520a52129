// Hexapod performance targets: forward kinematics per pose (< 5 µs) and a full calibration of
// 15 tests × 2 directions × 720 samples (< 2 s on one core).
#include <numbers>
#include <random>

#include <benchmark/benchmark.h>

#include "analysis/core/angles.h"
#include "analysis/hexapod/calibration.h"
#include "analysis/hexapod/kinematics.h"
#include "analysis/sim/hexapod_dbb_sim.h"
#include "tests/unit/hexapod/pm600_fixture.h"

namespace km::hexapod {
namespace {

struct FkCase {
  Vector6d struts;
  Pose guess;
};

std::vector<FkCase> MakeFkCases(bool near_guess) {
  const auto nominal = test::Pm600Like();
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<FkCase> cases;
  for (int i = 0; i < 1024; ++i) {
    Pose p;
    p.tip_mm = {200.0 * u(rng), 200.0 * u(rng), -1050.0 + 200.0 * u(rng)};
    p.abc_rad = Eigen::Vector3d(15.0 * u(rng), 15.0 * u(rng), 5.0 * u(rng)) * kDeg;
    FkCase c;
    c.struts = InverseKinematics(nominal, p, 100.0);  // commanded by the nominal model
    c.guess = p;                                      // the commanded pose (≈ 0.3 mm off)
    if (!near_guess) {
      c.guess = Pose();
      c.guess.tip_mm = {0, 0, -1050};  // home pose
    }
    cases.push_back(c);
  }
  return cases;
}

void BM_ForwardKinematicsFromCommandedPose(benchmark::State& state) {
  const auto truth = sim::PerturbGeometry(test::Pm600Like(), 0.3, 0.1, 1);
  const auto cases = MakeFkCases(true);
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& c = cases[i++ & 1023];
    benchmark::DoNotOptimize(ForwardKinematics(truth, c.struts, 100.0, c.guess));
  }
}
BENCHMARK(BM_ForwardKinematicsFromCommandedPose);

void BM_ForwardKinematicsFromHomePose(benchmark::State& state) {
  const auto truth = sim::PerturbGeometry(test::Pm600Like(), 0.3, 0.1, 1);
  const auto cases = MakeFkCases(false);
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& c = cases[i++ & 1023];
    benchmark::DoNotOptimize(ForwardKinematics(truth, c.struts, 100.0, c.guess));
  }
}
BENCHMARK(BM_ForwardKinematicsFromHomePose);

void BM_InverseKinematics(benchmark::State& state) {
  const auto g = test::Pm600Like();
  Pose p;
  p.tip_mm = {50, -20, -1000};
  p.abc_rad = {0.1, -0.05, 0.02};
  for (auto _ : state) {
    benchmark::DoNotOptimize(InverseKinematics(g, p, 100.0));
    p.tip_mm.x() += 1e-9;
  }
}
BENCHMARK(BM_InverseKinematics);

void BM_Calibration(benchmark::State& state) {
  const bool absolute = state.range(0) == 1;
  const auto nominal = test::Pm600Like();
  const auto truth = sim::PerturbGeometry(nominal, 0.3, 0.1, 3);
  sim::HexapodDbbSimOptions opt;
  opt.absolute = absolute;
  opt.noise_um = 0.3;
  const auto tests = sim::SimulateHexapodDbbPlan(nominal, truth, sim::Table21Plan(720, true), opt);
  CalibrationOptions o;
  o.method = absolute ? CalibrationMethod::kAbsolute : CalibrationMethod::kCentreCorrected;
  for (auto _ : state) {
    benchmark::DoNotOptimize(Calibrate(nominal, tests, o));
  }
  state.SetLabel(absolute ? "absolute, 30 x 721 samples" : "centre-corrected, 30 x 721 samples");
}
BENCHMARK(BM_Calibration)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->Iterations(2);

}  // namespace
}  // namespace km::hexapod

BENCHMARK_MAIN();
