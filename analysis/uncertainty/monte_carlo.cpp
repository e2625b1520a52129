#include "analysis/uncertainty/monte_carlo.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "analysis/core/errors.h"

namespace km::uncertainty {
namespace {

// std::seed_seq keeps 32 bits of each value: the 64-bit seed goes in as two halves.
std::uint32_t Low32(std::uint64_t v) {
  return static_cast<std::uint32_t>(v & 0xffffffffu);
}
std::uint32_t High32(std::uint64_t v) {
  return static_cast<std::uint32_t>(v >> 32);
}

// xoshiro256** ([Blackman & Vigna 2021]): the stream of the groups, ~1 ns a draw.
class Xoshiro256 {
 public:
  explicit Xoshiro256(std::seed_seq& seed) {
    std::array<std::uint32_t, 8> w{};
    seed.generate(w.begin(), w.end());
    for (int i = 0; i < 4; ++i) {
      s_[i] = (std::uint64_t{w[2 * i]} << 32) | w[2 * i + 1];
    }
    if ((s_[0] | s_[1] | s_[2] | s_[3]) == 0) s_[0] = 0x9e3779b97f4a7c15ull;
  }
  std::uint64_t Next() {
    const std::uint64_t result = Rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = Rotl(s_[3], 45);
    return result;
  }
  // Uniform on (0, 1): 53 bits, never 0 or 1.
  double Open01() { return (static_cast<double>(Next() >> 11) + 0.5) * 0x1.0p-53; }

 private:
  static std::uint64_t Rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::array<std::uint64_t, 4> s_{};
};

// The ziggurat of the standard normal density in 128 layers ([Marsaglia & Tsang 2000], with
// 53-bit draws: the layer from the low 7 bits, the abscissa from the top 53 bits of one draw).
class Ziggurat {
 public:
  Ziggurat() {
    constexpr double m = 0x1.0p52;
    double dn = kR;
    double tn = dn;
    const double q = kV / std::exp(-0.5 * dn * dn);
    k_[0] = static_cast<std::uint64_t>(dn / q * m);
    k_[1] = 0;
    w_[0] = q / m;
    w_[127] = dn / m;
    f_[0] = 1.0;
    f_[127] = std::exp(-0.5 * dn * dn);
    for (int i = 126; i >= 1; --i) {
      dn = std::sqrt(-2.0 * std::log(kV / dn + std::exp(-0.5 * dn * dn)));
      k_[i + 1] = static_cast<std::uint64_t>(dn / tn * m);
      tn = dn;
      f_[i] = std::exp(-0.5 * dn * dn);
      w_[i] = dn / m;
    }
  }
  double Draw(Xoshiro256& g) const {
    for (;;) {
      const std::uint64_t b = g.Next();
      const int i = static_cast<int>(b & 127u);
      const std::int64_t h = static_cast<std::int64_t>(b) >> 11;  // in [−2⁵², 2⁵²)
      const std::uint64_t a = static_cast<std::uint64_t>(h < 0 ? -h : h);
      const double x = static_cast<double>(h) * w_[i];
      if (a < k_[i]) return x;  // inside the layer's rectangle: ~99 % of draws
      if (i == 0) return Tail(g, h < 0);
      if (f_[i] + g.Open01() * (f_[i - 1] - f_[i]) < std::exp(-0.5 * x * x)) return x;
    }
  }

 private:
  static constexpr double kR = 3.442619855899;       // right end of the base layer
  static constexpr double kV = 9.91256303526217e-3;  // area of each layer
  static double Tail(Xoshiro256& g, bool negative) {
    double x = 0.0, y = 0.0;
    do {
      x = -std::log(g.Open01()) / kR;
      y = -std::log(g.Open01());
    } while (y + y < x * x);
    return negative ? -(kR + x) : kR + x;
  }
  std::array<std::uint64_t, 128> k_{};
  std::array<double, 128> w_{};
  std::array<double, 128> f_{};
};

const Ziggurat& NormalTable() {
  static const Ziggurat z;
  return z;
}

// Draws the inputs from their distributions out of one seeded stream (single inputs) and a
// second one seeded from it (groups).
class InputSampler {
 public:
  InputSampler(const std::vector<McInput>& inputs, std::seed_seq& seed)
      : inputs_(inputs), rng_(seed), group_rng_(seed), zig_(NormalTable()) {
    for (const auto& in : inputs) {
      const double scale = in.distribution == Distribution::kNormal        ? 1.0
                           : in.distribution == Distribution::kRectangular ? std::sqrt(3.0)
                                                                           : std::sqrt(6.0);
      scale_.push_back(scale * in.u);
    }
  }

  // Input i drawn once (its estimate when u = 0).
  double DrawOne(std::size_t i) {
    const McInput& in = inputs_[i];
    if (scale_[i] == 0.0) return in.estimate;
    switch (in.distribution) {
      case Distribution::kNormal:
        return in.estimate + scale_[i] * normal_(rng_);
      case Distribution::kRectangular:
        return in.estimate + scale_[i] * uniform_(rng_);
      case Distribution::kTriangular:
        // The mean of two independent R(−1, 1) is the symmetric triangle on [−1, 1].
        return in.estimate + scale_[i] * 0.5 * (uniform_(rng_) + uniform_(rng_));
    }
    return in.estimate;
  }

  // Input i into its `count` values (a single input: one value from DrawOne).
  void Draw(std::size_t i, std::span<double> x) {
    const McInput& in = inputs_[i];
    if (in.count == 1) {
      x[0] = DrawOne(i);
      return;
    }
    const double s = scale_[i];
    if (s == 0.0) {
      std::fill(x.begin(), x.end(), in.estimate);
      return;
    }
    switch (in.distribution) {
      case Distribution::kNormal:
        for (double& v : x) v = in.estimate + s * zig_.Draw(group_rng_);
        return;
      case Distribution::kRectangular:
        for (double& v : x) v = in.estimate + s * (2.0 * group_rng_.Open01() - 1.0);
        return;
      case Distribution::kTriangular:
        for (double& v : x) v = in.estimate + s * (group_rng_.Open01() - group_rng_.Open01());
        return;
    }
  }

  void DrawAll(std::span<double> x) {
    std::size_t at = 0;
    for (std::size_t i = 0; i < inputs_.size(); ++i) {
      Draw(i, x.subspan(at, inputs_[i].count));
      at += inputs_[i].count;
    }
  }

 private:
  const std::vector<McInput>& inputs_;
  std::mt19937_64 rng_;
  Xoshiro256 group_rng_;
  const Ziggurat& zig_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  std::uniform_real_distribution<double> uniform_{-1.0, 1.0};
  std::vector<double> scale_;  // σ, a or a of each input
};

void CheckRun(const VectorModel& model, const std::vector<McInput>& inputs, std::size_t outputs,
              const McOptions& o) {
  if (!model) throw InvalidInput("", 0, "model", "is empty");
  if (outputs == 0) throw InvalidInput("", 0, "outputs", "must be at least 1");
  for (const auto& in : inputs) {
    if (!(in.u >= 0.0 && std::isfinite(in.u) && std::isfinite(in.estimate))) {
      throw InvalidInput("", 0, in.name, "estimate and u must be finite, u not negative");
    }
    if (in.count == 0) throw InvalidInput("", 0, in.name, "a group of no draws");
  }
  o.Check();
}

// Appends `count` evaluations of the model to columns[j], one column per output. The buffers
// are allocated once; the columns grow by one reserve.
void DrawBatch(const VectorModel& model, InputSampler& sampler, std::size_t draw_size,
               std::size_t count, std::vector<std::vector<double>>& columns) {
  std::vector<double> x(draw_size);
  std::vector<double> y(columns.size());
  for (auto& c : columns) {
    if (c.capacity() < c.size() + count) c.reserve(std::max(c.size() + count, 2 * c.capacity()));
  }
  for (std::size_t m = 0; m < count; ++m) {
    sampler.DrawAll(x);
    model(x, y);
    for (std::size_t j = 0; j < y.size(); ++j) columns[j].push_back(y[j]);
  }
}

// Mean, u, U and the interval of one output from its draws (reordered).
McOutput Summarise(std::span<double> draws, double p, double k) {
  McOutput out;
  out.mean = Mean(draws);
  out.u = StandardDeviation(draws, out.mean);
  out.U = k * out.u;
  std::tie(out.low, out.high) = SymmetricCoverageInterval(draws, p);
  return out;
}

// The budget by one input at a time: input i drawn alone (its own stream, seeded by the run's
// seed and i), the others at their estimates; the σ of each output over `draws` evaluations
// (Welford's running variance, no storage).
void OneAtATimeBudget(const VectorModel& model, const std::vector<McInput>& inputs,
                      const McOptions& o, McResult& result) {
  const std::size_t n = inputs.size();
  const std::size_t outs = result.outputs.size();
  for (auto& out : result.outputs) out.budget.assign(n, 0.0);
  std::vector<double> x(DrawSize(inputs));
  std::vector<double> fixed(x.size());  // every input at its estimate
  for (std::size_t q = 0; q < n; ++q) {
    const auto at = static_cast<std::ptrdiff_t>(InputOffset(inputs, q));
    std::fill_n(fixed.begin() + at, inputs[q].count, inputs[q].estimate);
  }
  std::vector<double> y(outs);
  std::vector<double> mean(outs);
  std::vector<double> m2(outs);
  for (std::size_t i = 0; i < n; ++i) {
    if (inputs[i].u == 0.0) continue;
    std::seed_seq seed{Low32(o.seed), High32(o.seed), 1u, static_cast<std::uint32_t>(i)};
    InputSampler sampler(inputs, seed);
    x = fixed;
    const std::span<double> xi =
        std::span<double>(x).subspan(InputOffset(inputs, i), inputs[i].count);
    std::fill(mean.begin(), mean.end(), 0.0);
    std::fill(m2.begin(), m2.end(), 0.0);
    for (std::size_t m = 1; m <= o.budget_draws; ++m) {
      sampler.Draw(i, xi);
      model(x, y);
      for (std::size_t j = 0; j < outs; ++j) {
        const double d = y[j] - mean[j];
        mean[j] += d / static_cast<double>(m);
        m2[j] += d * (y[j] - mean[j]);
      }
    }
    for (std::size_t j = 0; j < outs; ++j) {
      result.outputs[j].budget[i] = std::sqrt(m2[j] / static_cast<double>(o.budget_draws - 1));
    }
  }
}

// The results of one batch for one output: y, u, y_low, y_high ([JCGM 101] §7.9.4).
struct BatchFigures {
  double mean, u, low, high;
};

// s of the average of h batch figures (§7.9.4): √(Σ (v_r − v̄)² / (h (h − 1))).
double SpreadOfAverage(const std::vector<BatchFigures>& b, double BatchFigures::*field) {
  const double h = static_cast<double>(b.size());
  double mean = 0.0;
  for (const auto& f : b) mean += f.*field;
  mean /= h;
  double ss = 0.0;
  for (const auto& f : b) ss += (f.*field - mean) * (f.*field - mean);
  return std::sqrt(ss / (h * (h - 1.0)));
}

// Whether 2s of every batch figure is within δ of u from all draws so far (§7.9.4).
bool BatchesStable(const std::vector<BatchFigures>& b, double u_all, int digits, double& delta) {
  delta = NumericalTolerance(u_all, digits);
  for (auto field :
       {&BatchFigures::mean, &BatchFigures::u, &BatchFigures::low, &BatchFigures::high}) {
    if (2.0 * SpreadOfAverage(b, field) > delta) return false;
  }
  return true;
}

// Mean and variance of all the draws so far, pooled from each batch's mean and u (Chan's
// parallel update), so a batch costs O(batch) whatever the draws before it.
class RunningMoments {
 public:
  void AddBatch(double mean, double u, std::size_t count) {
    const double nb = static_cast<double>(count);
    const double total = n_ + nb;
    const double d = mean - mean_;
    m2_ += u * u * (nb - 1.0) + d * d * n_ * nb / total;
    mean_ += d * nb / total;
    n_ = total;
  }
  double U() const { return n_ > 1.0 ? std::sqrt(m2_ / (n_ - 1.0)) : 0.0; }

 private:
  double n_ = 0.0;
  double mean_ = 0.0;
  double m2_ = 0.0;
};

// The adaptive procedure ([JCGM 101] §7.9.4): batches until every output is stable.
McResult RunAdaptive(const VectorModel& model, const std::vector<McInput>& inputs,
                     std::size_t outputs, const McOptions& o, InputSampler& sampler) {
  McResult result;
  std::vector<std::vector<double>> columns(outputs);
  std::vector<std::vector<BatchFigures>> batches(outputs);
  std::vector<double> scratch;
  std::vector<RunningMoments> all(outputs);
  result.converged = false;
  while (!result.converged && result.draws + o.batch <= o.max_draws) {
    DrawBatch(model, sampler, DrawSize(inputs), o.batch, columns);
    result.draws += o.batch;
    bool stable = batches[0].size() >= 1;  // two batches at least
    result.tolerance = 0.0;
    for (std::size_t j = 0; j < outputs; ++j) {
      scratch.assign(columns[j].end() - static_cast<std::ptrdiff_t>(o.batch), columns[j].end());
      const McOutput f = Summarise(scratch, o.p, o.k);
      batches[j].push_back({f.mean, f.u, f.low, f.high});
      all[j].AddBatch(f.mean, f.u, o.batch);
      if (batches[j].size() < 2) continue;
      double delta = 0.0;
      stable = BatchesStable(batches[j], all[j].U(), o.significant_digits, delta) && stable;
      result.tolerance = std::max(result.tolerance, delta);
    }
    result.converged = stable;
  }
  for (auto& c : columns) result.outputs.push_back(Summarise(c, o.p, o.k));
  return result;
}

}  // namespace

void McOptions::Check() const {
  if (!(p > 0.0 && p < 1.0)) throw InvalidInput("", 0, "p", "must be within (0, 1)");
  if (!(k > 0.0 && std::isfinite(k))) throw InvalidInput("", 0, "k", "must be a finite number > 0");
  // The interval needs M ≥ 1/(1 − p) draws ([JCGM 101] §7.2); a batch as much.
  const double least = 1.0 / (1.0 - p);
  const std::size_t m = adaptive ? batch : draws;
  if (static_cast<double>(m) < least) {
    throw InvalidInput("", 0, adaptive ? "batch" : "draws", "fewer than 1/(1 − p) draws");
  }
  if (adaptive && (significant_digits < 1 || max_draws < 2 * batch)) {
    throw InvalidInput("", 0, "adaptive", "needs 1+ significant digits and two batches");
  }
}

McInput McInput::Normal(std::string name, double x, double u) {
  return {std::move(name), x, u, Distribution::kNormal, 1};
}

McInput McInput::NormalGroup(std::string name, double x, double u, std::size_t count) {
  if (count == 0) throw InvalidInput("", 0, name, "a group of no draws");
  return {std::move(name), x, u, Distribution::kNormal, count};
}

std::size_t DrawSize(const std::vector<McInput>& inputs) {
  std::size_t n = 0;
  for (const auto& in : inputs) n += in.count;
  return n;
}

std::size_t InputOffset(const std::vector<McInput>& inputs, std::size_t i) {
  std::size_t at = 0;
  for (std::size_t q = 0; q < i && q < inputs.size(); ++q) at += inputs[q].count;
  return at;
}

McInput McInput::Rectangular(std::string name, double low, double high) {
  if (!(high >= low)) throw InvalidInput("", 0, name, "the upper bound is below the lower");
  return {std::move(name), 0.5 * (low + high), (high - low) / std::sqrt(12.0),
          Distribution::kRectangular, 1};
}

McInput McInput::Triangular(std::string name, double x, double half_width) {
  if (!(half_width >= 0.0)) throw InvalidInput("", 0, name, "the half-width is negative");
  return {std::move(name), x, half_width / std::sqrt(6.0), Distribution::kTriangular, 1};
}

double Mean(std::span<const double> draws) {
  if (draws.empty()) throw InvalidInput("", 0, "draws", "none");
  double sum = 0.0;
  for (double v : draws) sum += v;
  return sum / static_cast<double>(draws.size());
}

double StandardDeviation(std::span<const double> draws, double mean) {
  if (draws.size() < 2) throw InvalidInput("", 0, "draws", "fewer than two");
  double ss = 0.0;
  for (double v : draws) ss += (v - mean) * (v - mean);
  return std::sqrt(ss / static_cast<double>(draws.size() - 1));
}

std::pair<double, double> SymmetricCoverageInterval(std::span<double> draws, double p) {
  if (draws.empty()) throw InvalidInput("", 0, "draws", "none");
  if (!(p > 0.0 && p < 1.0)) throw InvalidInput("", 0, "p", "must be within (0, 1)");
  const std::size_t m = draws.size();
  const auto q = static_cast<std::size_t>(std::floor(p * static_cast<double>(m) + 0.5));
  std::size_t r = (m - q + 1) / 2;  // (M − q)/2, or (M − q + 1)/2 when that is not whole
  r = std::clamp<std::size_t>(r, 1, m);
  const std::size_t top = std::min(r + q, m);
  // 1-based order statistics y_(r) and y_(r+q); nth_element twice, O(M).
  // y_(r+q) is found among the draws above y_(r), which the second pass leaves in place.
  auto low = draws.begin() + static_cast<std::ptrdiff_t>(r - 1);
  std::nth_element(draws.begin(), low, draws.end());
  auto high = draws.begin() + static_cast<std::ptrdiff_t>(top - 1);
  if (high > low) std::nth_element(low + 1, high, draws.end());
  return {*low, *high};
}

double NumericalTolerance(double u, int significant_digits) {
  if (!(u > 0.0) || !std::isfinite(u)) return 0.0;
  const double l = std::floor(std::log10(u)) - (significant_digits - 1);
  return 0.5 * std::pow(10.0, l);
}

McResult PropagateMonteCarlo(const VectorModel& model, const std::vector<McInput>& inputs,
                             std::size_t outputs, const McOptions& options) {
  CheckRun(model, inputs, outputs, options);
  std::seed_seq seed{Low32(options.seed), High32(options.seed), 0u};
  InputSampler sampler(inputs, seed);
  McResult result;
  if (options.adaptive) {
    result = RunAdaptive(model, inputs, outputs, options, sampler);
  } else {
    std::vector<std::vector<double>> columns(outputs);
    DrawBatch(model, sampler, DrawSize(inputs), options.draws, columns);
    result.draws = options.draws;
    for (auto& c : columns) result.outputs.push_back(Summarise(c, options.p, options.k));
  }
  result.seed = options.seed;
  result.p = options.p;
  result.k = options.k;
  if (options.budget_draws >= 2) OneAtATimeBudget(model, inputs, options, result);
  return result;
}

}  // namespace km::uncertainty
