#include "analysis/form/periodic.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"

namespace km::form {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Residual sum of squares after fitting r ~ polynomial of degree `degree` in x (scaled by
// `half`) (+ a cos + b sin at frequency f when f > 0), and the fitted coefficients; the sine
// terms come last.
struct SineFit {
  double rss = 0.0;
  Eigen::VectorXd coef;
  Eigen::VectorXd fitted;
};

SineFit FitSine(std::span<const double> x, std::span<const double> r, int degree, double half,
                std::span<const double> freqs) {
  const Eigen::Index n = static_cast<Eigen::Index>(x.size());
  const Eigen::Index poly = degree + 1;
  const Eigen::Index cols = poly + 2 * static_cast<Eigen::Index>(freqs.size());
  Eigen::MatrixXd a(n, cols);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double xi = x[static_cast<std::size_t>(i)];
    double t = 1.0;
    for (Eigen::Index d = 0; d < poly; ++d) {
      a(i, d) = t;
      t *= xi / half;
    }
    for (std::size_t k = 0; k < freqs.size(); ++k) {
      const auto c = poly + 2 * static_cast<Eigen::Index>(k);
      a(i, c) = std::cos(kTwoPi * freqs[k] * xi);
      a(i, c + 1) = std::sin(kTwoPi * freqs[k] * xi);
    }
    y(i) = r[static_cast<std::size_t>(i)];
  }
  SineFit out;
  out.coef = a.colPivHouseholderQr().solve(y);
  out.fitted = a * out.coef;
  out.rss = (y - out.fitted).squaredNorm();
  return out;
}

// Generalised Lomb-Scargle power dRSS(f) of the model c + a cos + b sin, from the sums.
double PowerFromSums(double n, double ybar, double sc, double ss, double scc, double scs, double yc,
                     double ys) {
  const double sss = n - scc;
  const double ccc = scc - sc * sc / n;
  const double css = sss - ss * ss / n;
  const double ccs = scs - sc * ss / n;
  const double yyc = yc - ybar * sc;
  const double yys = ys - ybar * ss;
  const double det = ccc * css - ccs * ccs;
  if (!(det > 1e-12 * n * n)) return 0.0;
  return (css * yyc * yyc - 2.0 * ccs * yyc * yys + ccc * yys * yys) / det;
}

double PowerAt(std::span<const double> x, std::span<const double> r, double ybar, double f) {
  double sc = 0, ss = 0, scc = 0, scs = 0, yc = 0, ys = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double c = std::cos(kTwoPi * f * x[i]);
    const double s = std::sin(kTwoPi * f * x[i]);
    sc += c;
    ss += s;
    scc += c * c;
    scs += c * s;
    yc += r[i] * c;
    ys += r[i] * s;
  }
  return PowerFromSums(static_cast<double>(x.size()), ybar, sc, ss, scc, scs, yc, ys);
}

// Power on the grid f_k = f0 + k df, k < count. Rotation recurrences per point (vectorisable
// over the points), re-seeded with exact cos / sin every 64 frequencies.
std::vector<double> Periodogram(std::span<const double> x, std::span<const double> r, double f0,
                                double df, std::size_t count) {
  const std::size_t n = x.size();
  double ybar = 0.0;
  for (double v : r) ybar += v;
  ybar /= static_cast<double>(n);
  std::vector<double> c(n), s(n), cd(n), sd(n);
  for (std::size_t i = 0; i < n; ++i) {
    cd[i] = std::cos(kTwoPi * df * x[i]);
    sd[i] = std::sin(kTwoPi * df * x[i]);
  }
  std::vector<double> power(count, 0.0);
  for (std::size_t k = 0; k < count; ++k) {
    if (k % 64 == 0) {
      const double f = f0 + static_cast<double>(k) * df;
      for (std::size_t i = 0; i < n; ++i) {
        c[i] = std::cos(kTwoPi * f * x[i]);
        s[i] = std::sin(kTwoPi * f * x[i]);
      }
    }
    double sc = 0, ss = 0, scc = 0, scs = 0, yc = 0, ys = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double ci = c[i], si = s[i];
      sc += ci;
      ss += si;
      scc += ci * ci;
      scs += ci * si;
      yc += r[i] * ci;
      ys += r[i] * si;
      c[i] = ci * cd[i] - si * sd[i];
      s[i] = si * cd[i] + ci * sd[i];
    }
    power[k] = PowerFromSums(static_cast<double>(n), ybar, sc, ss, scc, scs, yc, ys);
  }
  return power;
}

// Index of the highest power on the grid f_k = f_lo + k df away from the frequencies already
// found (more than two grid steps); power.size() when there is none.
std::size_t StrongestPeak(const std::vector<double>& power, const std::vector<double>& found,
                          double f_lo, double df) {
  const std::size_t count = power.size();
  std::size_t best = count;
  for (std::size_t k = 0; k < count; ++k) {
    const double f = f_lo + static_cast<double>(k) * df;
    const bool excluded = std::any_of(found.begin(), found.end(),
                                      [&](double g) { return std::abs(f - g) < 2.0 * df; });
    if (excluded) continue;
    if (best == count || power[k] > power[best]) best = k;
  }
  return best;
}

// Golden-section refinement of the peak at grid frequency f_best (power p_best) within one grid
// step either side, inside [f_lo, f_hi]; f_best when the refinement finds no more power.
double RefinePeak(std::span<const double> xc, std::span<const double> r, double f_best,
                  double p_best, double f_lo, double f_hi, double df) {
  double ybar = 0.0;
  for (double v : r) ybar += v;
  ybar /= static_cast<double>(r.size());
  double a = std::max(f_lo, f_best - df), b = std::min(f_hi, f_best + df);
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double c1 = b - g * (b - a), c2 = a + g * (b - a);
  double p1 = PowerAt(xc, r, ybar, c1), p2 = PowerAt(xc, r, ybar, c2);
  for (int it = 0; it < 40; ++it) {
    if (p1 > p2) {
      b = c2;
      c2 = c1;
      p2 = p1;
      c1 = b - g * (b - a);
      p1 = PowerAt(xc, r, ybar, c1);
    } else {
      a = c1;
      c1 = c2;
      p1 = p2;
      c2 = a + g * (b - a);
      p2 = PowerAt(xc, r, ybar, c2);
    }
  }
  const double f = 0.5 * (a + b);
  return PowerAt(xc, r, ybar, f) < p_best ? f_best : f;
}

}  // namespace

void PeriodicOptions::Check() const {
  KM_OPTION_GE(min_period_mm, 0.0);  // 0 = automatic
  KM_OPTION_GE(max_period_mm, 0.0);  // 0 = automatic
  if (min_period_mm > 0.0 && max_period_mm > 0.0) KM_OPTION_GT(max_period_mm, min_period_mm);
  KM_OPTION_IN(oversampling, 1.0, 100.0);
  KM_OPTION_IN_OPEN(false_alarm_probability, 0.0, 1.0);
  KM_OPTION_IN(detrend_degree, 0, 5);
  KM_OPTION_IN(max_components, 0, 50);
}

std::vector<PeriodicComponent> FindPeriodicComponents(std::span<const double> position_mm,
                                                      std::span<const double> residual_um,
                                                      const PeriodicOptions& options) {
  options.Check();
  if (position_mm.size() != residual_um.size()) {
    throw InvalidInput("periodic components: positions and residuals differ in size");
  }
  const std::size_t n = position_mm.size();
  std::vector<PeriodicComponent> out;
  if (n < 8 || options.max_components == 0) return out;

  std::vector<double> sorted(position_mm.begin(), position_mm.end());
  std::sort(sorted.begin(), sorted.end());
  const double length = sorted.back() - sorted.front();
  if (!(length > 0.0)) return out;
  std::vector<double> gaps;
  for (std::size_t i = 1; i < n; ++i) {
    if (sorted[i] > sorted[i - 1]) gaps.push_back(sorted[i] - sorted[i - 1]);
  }
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2),
                   gaps.end());
  const double median_gap = gaps[gaps.size() / 2];
  const double min_period = options.min_period_mm > 0.0
                                ? options.min_period_mm
                                : std::max(2.5 * median_gap, length / 500.0);
  const double max_period = options.max_period_mm > 0.0 ? options.max_period_mm : length / 2.5;
  if (!(max_period > min_period)) return out;
  const double f_lo = 1.0 / max_period;
  const double f_hi = 1.0 / min_period;
  const double df = 1.0 / (options.oversampling * length);
  const auto count = static_cast<std::size_t>(std::floor((f_hi - f_lo) / df)) + 1;
  if (count > 1'000'000) {
    throw InvalidInput("", 0, "min_period_mm",
                       "the period range asks for more than 10^6 trial frequencies");
  }
  // Bonferroni over every trial frequency (conservative: the grid is oversampled).
  const double independent = static_cast<double>(count);

  // Centred positions for the search (the power does not depend on the origin).
  double mean_x = 0.0;
  for (double v : position_mm) mean_x += v;
  mean_x /= static_cast<double>(n);
  std::vector<double> xc(n);
  for (std::size_t i = 0; i < n; ++i) xc[i] = position_mm[i] - mean_x;
  const int degree = options.detrend_degree;
  const double half = 0.5 * length;
  const std::size_t params = static_cast<std::size_t>(degree) + 3;
  if (n <= params + 2) return out;
  // Smooth form (bow, curvature) is removed first so it does not show up as long periods.
  std::vector<double> r(residual_um.begin(), residual_um.end());
  {
    const SineFit base = FitSine(xc, r, degree, half, {});
    for (std::size_t i = 0; i < n; ++i) r[i] -= base.fitted(static_cast<Eigen::Index>(i));
  }
  std::vector<double> found;

  for (int comp = 0; comp < options.max_components; ++comp) {
    const std::vector<double> power = Periodogram(xc, r, f_lo, df, count);
    const std::size_t best = StrongestPeak(power, found, f_lo, df);
    if (best == count || !(power[best] > 0.0)) break;
    const double f =
        RefinePeak(xc, r, f_lo + static_cast<double>(best) * df, power[best], f_lo, f_hi, df);

    const SineFit null_fit = FitSine(xc, r, degree, half, {});
    const double one[] = {f};
    const SineFit sine_fit = FitSine(xc, r, degree, half, one);
    if (!(sine_fit.rss > 0.0)) break;
    const double sigma2 = sine_fit.rss / static_cast<double>(n - params);
    const double z = std::max(0.0, null_fit.rss - sine_fit.rss) / (2.0 * sigma2);
    const double fap = -std::expm1(independent * std::log1p(-std::exp(-z)));
    if (!(fap < options.false_alarm_probability)) break;
    found.push_back(f);
    PeriodicComponent pc;
    pc.period_mm = 1.0 / f;
    pc.false_alarm_probability = fap;
    out.push_back(pc);
    // Remove the fitted sinusoid (and baseline) before searching for the next component.
    for (std::size_t i = 0; i < n; ++i) r[i] -= sine_fit.fitted(static_cast<Eigen::Index>(i));
  }
  if (out.empty()) return out;

  // Joint amplitude fit at the found frequencies with the polynomial baseline, on the input.
  // The sine terms use centred positions; phases are then referred to position 0.
  const SineFit joint = FitSine(xc, residual_um, degree, half, found);
  for (std::size_t k = 0; k < out.size(); ++k) {
    const auto c = static_cast<Eigen::Index>(degree + 1) + 2 * static_cast<Eigen::Index>(k);
    const double ca = joint.coef(c);
    const double sb = joint.coef(c + 1);
    out[k].amplitude_um = std::hypot(ca, sb);
    // a cos(w xc) + b sin(w xc) = A cos(w x - w mean_x - phi_c), phi_c = atan2(b, a).
    out[k].phase_rad = std::remainder(std::atan2(sb, ca) + kTwoPi * found[k] * mean_x, kTwoPi);
  }
  return out;
}

}  // namespace km::form
