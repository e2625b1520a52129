// Propagation of distributions by Monte Carlo ([JCGM 101] §5–§7): M draws of independent input
// quantities, each drawn from its distribution (normal, rectangular, triangular), a vector-valued
// model evaluated for each draw, and for each output quantity the estimate (the mean of the
// draws, §7.6), the standard uncertainty (their standard deviation, §7.6), the probabilistically
// symmetric coverage interval from the order statistics (§7.7) and U = 2u. The budget is by one
// input at a time: each input drawn alone with the others at their estimates. The adaptive
// procedure (§7.9) adds batches until the results are stable to the numerical tolerance of a
// stated number of significant digits of u. Seeded std::mt19937_64: one seed, one result.
// An input may stand for a group of `count` independent draws of one distribution (e.g. the
// reading of an instrument, drawn anew for each of thousands of readings): the model sees all
// of them, the budget one entry for the group. Groups draw from their own seeded stream
// (xoshiro256**, normals by the ziggurat method [Marsaglia & Tsang 2000]), fast enough for
// thousands of draws per evaluation. A pure numerical module: no I/O.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace km::uncertainty {

enum class Distribution {
  kNormal,       // N(x, u²)
  kRectangular,  // R(x − a, x + a), a = √3·u
  kTriangular,   // symmetric T(x − a, x + a), a = √6·u
};

// One input quantity by its estimate and standard uncertainty (k = 1); u = 0 holds it fixed.
// count > 1: a group of `count` independent quantities of that one distribution, drawn
// independently of each other at every evaluation (x holds `count` values for it).
struct McInput {
  std::string name;
  double estimate = 0.0;
  double u = 0.0;
  Distribution distribution = Distribution::kNormal;
  std::size_t count = 1;

  static McInput Normal(std::string name, double x, double u);
  // `count` independent N(x, u²) quantities, one budget entry.
  static McInput NormalGroup(std::string name, double x, double u, std::size_t count);
  // R(low, high): estimate (low + high)/2, u = (high − low)/√12.
  static McInput Rectangular(std::string name, double low, double high);
  // Symmetric triangle of half-width a about x: u = a/√6.
  static McInput Triangular(std::string name, double x, double half_width);
};

// The model: fills y (one value per output quantity) from one draw x of the inputs, the inputs'
// values in their order, a group's `count` values one after the other (InputOffset). Called
// once per draw; it should not allocate. (The first-order check of cross_check.h evaluates
// inputs of count 1 only: give it a model of those.)
using VectorModel = std::function<void(std::span<const double> x, std::span<double> y)>;

struct McOptions {
  std::size_t draws = 1'000'000;  // M of a fixed-size run
  std::uint64_t seed = 1;
  double p = 0.95;                    // coverage probability of the interval
  double k = 2.0;                     // U = k·u
  std::size_t budget_draws = 10'000;  // draws per input of the budget; 0: no budget
  // Adaptive procedure ([JCGM 101] §7.9.4): batches of `batch` draws until twice the standard
  // deviation of every batch result (mean, u, both ends of the interval) is at most the
  // numerical tolerance δ of `significant_digits` digits of u, or `max_draws` are spent.
  bool adaptive = false;
  std::size_t batch = 10'000;
  int significant_digits = 2;
  std::size_t max_draws = 10'000'000;
  // Throws km::InvalidInput naming the option: p in (0, 1), k > 0, a run (or a batch) of at
  // least 1/(1 − p) draws ([JCGM 101] §7.2), an adaptive run of 1+ digits and two batches.
  void Check() const;
};

// The results for one output quantity.
struct McOutput {
  double mean = 0.0;  // estimate y ([JCGM 101] §7.6)
  double u = 0.0;     // standard deviation of the draws (§7.6)
  double U = 0.0;     // k·u
  double low = 0.0;   // probabilistically symmetric coverage interval [low, high] (§7.7)
  double high = 0.0;
  std::vector<double> budget;  // per input: σ of this output with that input drawn alone
};

struct McResult {
  std::size_t draws = 0;  // M (adaptive: the total of the batches)
  std::uint64_t seed = 0;
  double p = 0.95;
  double k = 2.0;
  bool converged = true;   // adaptive: the tolerance was met within max_draws
  double tolerance = 0.0;  // adaptive: the largest δ of the outputs
  std::vector<McOutput> outputs;
};

// Number of values x holds for `inputs` (Σ count), and where input i's values start in x.
std::size_t DrawSize(const std::vector<McInput>& inputs);
std::size_t InputOffset(const std::vector<McInput>& inputs, std::size_t i);

// Runs the propagation of `outputs` output quantities through `model`.
McResult PropagateMonteCarlo(const VectorModel& model, const std::vector<McInput>& inputs,
                             std::size_t outputs, const McOptions& options = {});

// Summaries of a set of draws of one output (used by both procedures; `draws` is reordered).
double Mean(std::span<const double> draws);
double StandardDeviation(std::span<const double> draws, double mean);
// The probabilistically symmetric 100p % interval [y_(r), y_(r+q)] of the order statistics,
// q = pM rounded, r = (M − q)/2 rounded up when not whole ([JCGM 101] §7.7).
std::pair<double, double> SymmetricCoverageInterval(std::span<double> draws, double p);
// The numerical tolerance δ = ½·10^l of u written as c·10^l with c of n digits ([JCGM 101] §7.9.2).
double NumericalTolerance(double u, int significant_digits);

}  // namespace km::uncertainty
