// Monte Carlo propagation throughput ([JCGM 101]): a model of 10 inputs and 6 outputs (sums,
// squares, a range, a product, a phase and a norm, the kinds of figures the analyses report),
// M = 10⁵ draws. Reported: the time without the budget (argument 0) and with the budget by one
// input at a time of 10⁴ draws per input (argument 1, 10⁵ more evaluations).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

#include "analysis/uncertainty/monte_carlo.h"

namespace {

void SixFigures(std::span<const double> x, std::span<double> y) {
  double sum = 0.0;
  double squares = 0.0;
  double phase = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sum += x[i];
    squares += x[i] * x[i];
    phase += std::sin(0.3 * static_cast<double>(i) + x[i]);
  }
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  y[0] = sum;
  y[1] = squares;
  y[2] = *hi - *lo;
  y[3] = x[0] * x[1] - x[2] * x[3];
  y[4] = phase;
  y[5] = std::sqrt(squares);
}

std::vector<km::uncertainty::McInput> TenInputs() {
  using km::uncertainty::McInput;
  std::vector<McInput> in;
  for (int i = 0; i < 10; ++i) {
    const double x = 1.0 + 0.5 * i;
    if (i % 3 == 0) {
      in.push_back(McInput::Normal("n", x, 0.1));
    } else if (i % 3 == 1) {
      in.push_back(McInput::Rectangular("r", x - 0.2, x + 0.2));
    } else {
      in.push_back(McInput::Triangular("t", x, 0.2));
    }
  }
  return in;
}

void BM_MonteCarlo10In6Out(benchmark::State& state) {
  const auto inputs = TenInputs();
  km::uncertainty::McOptions o;
  o.draws = 100'000;
  o.budget_draws = state.range(0) != 0 ? 10'000 : 0;
  for (auto _ : state) {
    const auto r = km::uncertainty::PropagateMonteCarlo(SixFigures, inputs, 6, o);
    benchmark::DoNotOptimize(r.outputs[5].u);
  }
}
BENCHMARK(BM_MonteCarlo10In6Out)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
