// The steady-motion fit of the feed-drive analysis (feed_drive.h, step 1): Coulomb, viscous,
// moving mass and the position-dependent ripple.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/core/errors.h"
#include "analysis/core/gram.h"
#include "analysis/core/parallel.h"
#include "analysis/core/sincos.h"
#include "analysis/servo/feed_drive_detail.h"

namespace km::servo::detail {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
// Columns of the steady fit before the ripple: offset, slope, Coulomb, viscous, moving mass.
constexpr int kBase = 5;
// The base columns of one sample (no heap per sample).
using Column = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kBase + 3 * 20, 1>;

using Component = RippleComponent;

double Sign(double v) {
  return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
}

// The steady samples of a fit in the records' order, with √w (Strokes::Weight with the moving
// mass given), the weighted target √w (f − known), and Σ w (f − known)² and Σ w, each summed
// over the two halves of the record and then added.
struct Rows {
  std::vector<std::size_t> index;
  Eigen::ArrayXd sw;
  Eigen::VectorXd y;
  double btb = 0.0, weights = 0.0;
};

Rows RowsOf(const Strokes& s, double mass) {
  Rows r;
  for (std::size_t i = 0; i < s.x.size(); ++i)
    if (s.steady[i]) r.index.push_back(i);
  const auto n = static_cast<Eigen::Index>(r.index.size());
  r.sw.resize(n);
  r.y.resize(n);
  const std::size_t mid = s.x.size() / 2;
  std::array<double, 2> btb{}, weights{};
  for (Eigen::Index k = 0; k < n; ++k) {
    const std::size_t i = r.index[static_cast<std::size_t>(k)], half = i < mid ? 0 : 1;
    const double w = s.Weight(i, mass), b = s.f[i] - s.Known(i), sw = std::sqrt(w);
    r.sw[k] = sw;
    r.y[k] = sw * b;
    btb[half] += w * b * b;
    weights[half] += w;
  }
  r.btb = btb[0] + btb[1];
  r.weights = weights[0] + weights[1];
  return r;
}

// The rows of the fit a block at a time (so that a block's columns stay in the first-level
// cache while their products are summed).
constexpr std::size_t kRowBlock = 256;

// The columns of a Gram matrix: a ripple component's (2, or 3 with ∂/∂P), the fit's, and all
// (the fit's, the target, the extra ones).
struct GramLayout {
  int per = 2, p = kBase, m = kBase + 1;
};

// Gram's products over the rows first … last − 1, added to g (its lower half).
void AddRowsToGram(const Strokes& s, const Rows& r, const std::vector<Component>& comps,
                   const std::vector<const std::vector<double>*>& extra, const GramLayout& l,
                   std::size_t first_row, std::size_t last_row, double* g) {
  std::vector<double> buffer(static_cast<std::size_t>(l.m) * kRowBlock), w(kRowBlock),
      sn(kRowBlock), cs(kRowBlock);
  std::vector<double*> col(static_cast<std::size_t>(l.m));
  for (std::size_t j = 0; j < col.size(); ++j) col[j] = buffer.data() + j * kRowBlock;
  const auto p = static_cast<std::size_t>(l.p);
  for (std::size_t first = first_row; first < last_row; first += kRowBlock) {
    const std::size_t len = std::min(kRowBlock, last_row - first);
    for (std::size_t t = 0; t < len; ++t) {
      const std::size_t i = r.index[first + t];
      const double sw = r.sw[static_cast<Eigen::Index>(first + t)];
      col[0][t] = sw;
      col[1][t] = sw * s.x[i];
      col[2][t] = sw * Sign(s.v[i]);
      col[3][t] = sw * s.v[i];
      col[4][t] = sw * (1e-3 * s.a[i]);
      col[p][t] = r.y[static_cast<Eigen::Index>(first + t)];
      for (std::size_t e = 0; e < extra.size(); ++e) col[p + 1 + e][t] = sw * (*extra[e])[i];
    }
    for (std::size_t c = 0; c < comps.size(); ++c) {
      const Component& q = comps[c];
      for (std::size_t t = 0; t < len; ++t) w[t] = kTwoPi * s.x[r.index[first + t]] / q.period;
      SinCosArray(w.data(), sn.data(), cs.data(), len);
      double* const* out = col.data() + kBase + static_cast<std::size_t>(l.per) * c;
      for (std::size_t t = 0; t < len; ++t) {
        const double sw = r.sw[static_cast<Eigen::Index>(first + t)];
        out[0][t] = sw * cs[t];
        out[1][t] = sw * sn[t];
        if (l.per == 3) out[2][t] = sw * ((w[t] / q.period) * (q.a * sn[t] - q.b * cs[t]));
      }
    }
    AddGram(col.data(), l.m, len, g);
  }
}

// The Gram matrix (all products, summed over the rows) of the fit's columns scaled by √w —
// offset, slope, Coulomb, viscous, moving mass, then for each ripple component cos w and sin w
// (w = 2πx/P) and, `by_period`, the derivative of a cos w + b sin w in P — followed by the
// weighted target √w (f − known) and √w times each of `extra` (given for every sample). The
// two halves of the rows are summed side by side and then added.
Eigen::MatrixXd Gram(const Strokes& s, const Rows& r, const std::vector<Component>& comps,
                     bool by_period, const std::vector<const std::vector<double>*>& extra = {}) {
  GramLayout l;
  l.per = by_period ? 3 : 2;
  l.p = kBase + l.per * static_cast<int>(comps.size());
  l.m = l.p + 1 + static_cast<int>(extra.size());
  std::array<Eigen::MatrixXd, 2> half;
  const std::size_t mid = r.index.size() / 2;
  ParallelFor(2, [&](std::size_t k) {
    half[k] = Eigen::MatrixXd::Zero(l.m, l.m);
    AddRowsToGram(s, r, comps, extra, l, k == 0 ? 0 : mid, k == 0 ? mid : r.index.size(),
                  half[k].data());
  });
  Eigen::MatrixXd g = half[0] + half[1];
  g.triangularView<Eigen::StrictlyUpper>() = g.transpose();
  return g;
}

// Weighted least squares of the rows `r` from the Gram matrix `g` of their p columns and the
// target (Gram); returns the coefficients, their covariance and the residual's (weighted) RMS.
Eigen::VectorXd Solve(const Rows& r, const Eigen::MatrixXd& g, Eigen::Index p, Eigen::MatrixXd* cov,
                      double* rms) {
  const double n = static_cast<double>(r.index.size());
  const Eigen::VectorXd atb = g.col(p).head(p);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(g.topLeftCorner(p, p));
  const Eigen::VectorXd x = ldlt.solve(atb);
  const double wss = std::max(0.0, r.btb - x.dot(atb));  // Σ w e², A x = b in the mean
  if (rms) *rms = std::sqrt(wss / std::max(r.weights, 1e-300));
  if (cov) {
    *cov = (wss / std::max(n - static_cast<double>(p), 1.0)) *
           ldlt.solve(Eigen::MatrixXd::Identity(p, p));
  }
  return x;
}

// The fit of the base columns and (with ∂/∂P) the components `comps`.
Eigen::VectorXd SolveFit(const Strokes& s, const Rows& r, const std::vector<Component>& comps,
                         Eigen::MatrixXd* cov, double* rms) {
  const auto p = static_cast<Eigen::Index>(kBase + 3 * comps.size());
  return Solve(r, Gram(s, r, comps, !comps.empty()), p, cov, rms);
}

// Noise of one sample: the spread of the differences of consecutive residuals (robust: the
// median absolute difference; slow parts such as the ripple cancel).
double NoiseOf(const Strokes& s, const std::vector<double>& e) {
  std::vector<double> d;
  for (std::size_t i = 0; i + 1 < s.x.size(); ++i) {
    if (s.steady[i] && s.steady[i + 1]) d.push_back(std::abs(e[i + 1] - e[i]));
  }
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return 1.4826 * d[d.size() / 2] / std::sqrt(2.0);
}

// Whether the strokes agree with the friction law: the mean residual of each stroke against
// its noise, χ² over the strokes less the offset, Coulomb and viscous terms that fit them. The
// ratio √(χ²/dof) (at least 1) scales the σ of Coulomb and viscous friction: strokes that
// disagree (a Stribeck rise left at the slowest feed, a drift) widen them, as they should.
template <typename Residual>
double StrokeBirgeRatio(const Strokes& s, double mass, Residual residual) {
  std::vector<double> sum, weight;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!s.steady[i]) continue;
    const std::size_t k = s.stroke[i];
    if (k >= sum.size()) {
      sum.resize(k + 1, 0.0);
      weight.resize(k + 1, 0.0);
    }
    const double w = s.Weight(i, mass);
    sum[k] += w * residual(i);
    weight[k] += w;
  }
  double chi2 = 0.0;
  int strokes = 0;
  for (std::size_t k = 0; k < sum.size(); ++k) {
    if (!(weight[k] > 0.0)) continue;
    const double mean = sum[k] / weight[k], sd = s.noise_N / std::sqrt(weight[k]);
    if (sd > 0.0) chi2 += (mean / sd) * (mean / sd);
    ++strokes;
  }
  const int dof = strokes - 3;
  return dof >= 1 ? std::max(1.0, std::sqrt(chi2 / dof)) : 1.0;
}

// How Coulomb and viscous friction move when the strokes at the slowest feed are left out
// (the Stribeck rise reaches the slowest feed first): the shifts larger than twice their own
// σ, else zero. Needs two feeds at least 1.5 × apart besides the slowest.
Eigen::Vector2d SlowestFeedShift(Strokes& s, double mass, const std::vector<Component>& comps,
                                 const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
  double slowest = INFINITY;
  for (std::size_t i = 0; i < s.x.size(); ++i)
    if (s.steady[i]) slowest = std::min(slowest, s.stroke_top[s.stroke[i]]);
  double lo = INFINITY, hi = 0.0;  // the other feeds
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    const double top = s.stroke_top[s.stroke[i]];
    if (s.steady[i] && top >= 1.5 * slowest) {
      lo = std::min(lo, top);
      hi = std::max(hi, top);
    }
  }
  if (!(hi >= 1.5 * lo)) return Eigen::Vector2d::Zero();
  const std::vector<bool> all = s.steady;
  for (std::size_t i = 0; i < s.x.size(); ++i)
    if (s.steady[i] && s.stroke_top[s.stroke[i]] < 1.5 * slowest) s.steady[i] = false;
  Eigen::MatrixXd cov2;
  const Rows rows = RowsOf(s, mass);
  const Eigen::VectorXd x2 = SolveFit(s, rows, comps, &cov2, nullptr);
  s.steady = all;
  Eigen::Vector2d out;
  for (int k = 0; k < 2; ++k) {
    const double d = x2[2 + k] - x[2 + k];
    const double sd = std::sqrt(std::max(0.0, cov2(2 + k, 2 + k) - cov(2 + k, 2 + k)));
    out[k] = std::abs(d) > 2.0 * sd ? d : 0.0;
  }
  return out;
}

// The steady fit's columns before the ripple at sample i: offset, slope, Coulomb, viscous, mass.
Column BaseColumn(const Strokes& s, std::size_t i) {
  Column c(kBase);
  c << 1.0, s.x[i], Sign(s.v[i]), s.v[i], 1e-3 * s.a[i];
  return c;
}

// The ripple Σ a cos(2πx/P) + b sin(2πx/P) over the components at every position of `x`, the
// components added in their order; each component's sines and cosines taken at once.
std::vector<double> RippleOf(const std::vector<Component>& comps, const std::vector<double>& x) {
  std::vector<double> v(x.size(), 0.0), w(x.size()), sn(x.size()), cs(x.size());
  for (const auto& c : comps) {
    for (std::size_t i = 0; i < x.size(); ++i) w[i] = kTwoPi * x[i] / c.period;
    SinCosArray(w.data(), sn.data(), cs.data(), x.size());
    for (std::size_t i = 0; i < x.size(); ++i) v[i] += c.a * cs[i] + c.b * sn[i];
  }
  return v;
}

// r.ripple: the components with their σ (from the joint fit's covariance `cov`), largest first;
// reported are those above 4 σ of their amplitude and 5 % of the largest (the others stay in
// the fit, where they cost nothing).
void ReportRipples(const std::vector<Component>& comps, const Eigen::MatrixXd& cov,
                   FeedDriveResult& r) {
  for (std::size_t k = 0; k < comps.size(); ++k) {
    const int ia = kBase + 3 * static_cast<int>(k), ib = ia + 1;
    Ripple rp;
    rp.period_mm = comps[k].period;
    rp.period_sigma_mm = std::sqrt(std::max(0.0, cov(ib + 1, ib + 1)));
    rp.amplitude_N = std::hypot(comps[k].a, comps[k].b);
    const double a = comps[k].a, b = comps[k].b, amp2 = rp.amplitude_N * rp.amplitude_N;
    rp.amplitude_sigma_N = std::sqrt(
        std::max(0.0, (a * a * cov(ia, ia) + b * b * cov(ib, ib) + 2 * a * b * cov(ia, ib)) /
                          std::max(amp2, 1e-300)));
    rp.phase_deg = std::atan2(b, a) * 180.0 / std::numbers::pi;
    r.ripple.push_back(rp);
  }
  std::sort(r.ripple.begin(), r.ripple.end(),
            [](const Ripple& l, const Ripple& q) { return l.amplitude_N > q.amplitude_N; });
  const double largest = r.ripple.empty() ? 0.0 : r.ripple.front().amplitude_N;
  std::erase_if(r.ripple, [&](const Ripple& q) {
    return !(q.amplitude_N > 4.0 * q.amplitude_sigma_N && q.amplitude_N >= 0.05 * largest);
  });
}

}  // namespace

void FitSteady(Strokes& s, const FeedDriveOptions& o, FeedDriveResult& r) {
  // 1. Without the ripple: offset, slope, Coulomb, viscous.
  const auto base = [&](std::size_t i) { return BaseColumn(s, i); };
  s.noise_N = 0.0;  // unweighted first
  const Rows unweighted = RowsOf(s, 0.0);
  const Eigen::VectorXd b0 = SolveFit(s, unweighted, {}, nullptr, nullptr);
  const double mass = b0[4];
  std::vector<double> e0(s.x.size(), 0.0);
  for (std::size_t i = 0; i < s.x.size(); ++i)
    if (s.steady[i]) e0[i] = s.f[i] - s.Known(i) - base(i).dot(b0);
  s.noise_N = NoiseOf(s, e0);
  // 2. The position-dependent part binned (eq. 4.8: the direction-dependent part is removed).
  double xmin = INFINITY, xmax = -INFINITY;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!s.steady[i]) continue;
    xmin = std::min(xmin, s.x[i]);
    xmax = std::max(xmax, s.x[i]);
  }
  const auto nb = static_cast<std::size_t>(std::ceil((xmax - xmin) / o.bin_mm)) + 1;
  std::vector<double> sum(nb, 0.0), cnt(nb, 0.0);
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!s.steady[i]) continue;
    const auto b = static_cast<std::size_t>((s.x[i] - xmin) / o.bin_mm);
    const double w = s.Weight(i, mass);
    sum[b] += w * e0[i];
    cnt[b] += w;
  }
  std::vector<double> xc, y;
  for (std::size_t b = 0; b < nb; ++b) {
    if (!(cnt[b] > 0.0)) continue;
    xc.push_back(xmin + (static_cast<double>(b) + 0.5) * o.bin_mm);
    y.push_back(sum[b] / cnt[b]);
  }
  const double pmin = o.min_period_mm > 0.0 ? o.min_period_mm : 4.0 * o.bin_mm;
  const double pmax = o.max_period_mm > 0.0 ? o.max_period_mm : (xmax - xmin) / 2.0;
  std::vector<Component> comps = FindPeriods(xc, y, pmin, pmax, o.max_ripple_components);
  // 3. Everything together; Gauss–Newton on the periods (columns ∂/∂P).
  const int nc = static_cast<int>(comps.size());
  Eigen::VectorXd x;
  Eigen::MatrixXd cov;
  double rms = 0.0;
  const Rows rows = RowsOf(s, mass);
  for (int it = 0; it < 4; ++it) {
    x = SolveFit(s, rows, comps, &cov, &rms);
    for (int k = 0; k < nc; ++k) {
      comps[k].a = x[kBase + 3 * k];
      comps[k].b = x[kBase + 1 + 3 * k];
      // A Gauss–Newton step on the period, at most 2 % at a time.
      const double step = x[kBase + 2 + 3 * k], limit = 0.02 * comps[k].period;
      comps[k].period += std::clamp(step, -limit, limit);
    }
  }
  const std::vector<double> ripple = RippleOf(comps, s.x);
  const double birge = StrokeBirgeRatio(s, mass, [&](std::size_t i) {
    return s.f[i] - s.Known(i) - base(i).dot(x.head<kBase>()) - ripple[i];
  });
  const Eigen::Vector2d shift = SlowestFeedShift(s, mass, comps, x, cov);
  r.offset_N = x[0];
  r.slope_N_per_mm = x[1];
  r.coulomb_N = x[2];
  r.coulomb_sigma_N = std::hypot(birge * std::sqrt(cov(2, 2)), shift[0]);
  r.viscous_N_s_per_mm = x[3];
  r.viscous_sigma_N_s_per_mm = std::hypot(birge * std::sqrt(cov(3, 3)), shift[1]);
  r.moving_mass_kg = x[4];
  r.residual_rms_N = rms;
  for (std::size_t i = 0; i < s.x.size(); ++i) r.steady_samples += s.steady[i];
  ReportRipples(comps, cov, r);
  s.steady_mass_kg = mass;
  s.ripple_periods.clear();
  for (const auto& c : comps) s.ripple_periods.push_back(c.period);
  s.position_part.resize(s.x.size());
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    s.position_part[i] = x[0] + x[1] * s.x[i] + ripple[i];
  }
}

std::vector<Eigen::Vector2d> SteadyShifts(const Strokes& s,
                                          const std::vector<std::vector<double>>& deltas) {
  // The fit's columns (the periods held) and the shifts, weighted as in the fit.
  std::vector<Component> comps;
  for (double period : s.ripple_periods) comps.push_back({period, 0.0, 0.0});
  std::vector<const std::vector<double>*> extra;
  for (const auto& d : deltas) extra.push_back(&d);
  const Rows rows = RowsOf(s, s.steady_mass_kg);
  const Eigen::MatrixXd g = Gram(s, rows, comps, false, extra);
  const auto p = static_cast<Eigen::Index>(kBase + 2 * comps.size());
  const auto nd = static_cast<Eigen::Index>(deltas.size());
  const Eigen::MatrixXd shifts = g.topLeftCorner(p, p).ldlt().solve(g.block(0, p + 1, p, nd));
  std::vector<Eigen::Vector2d> out;
  for (Eigen::Index k = 0; k < nd; ++k) {
    out.emplace_back(-shifts(2, k), -shifts(3, k));  // the known part grew: the fit's part shrinks
  }
  return out;
}

}  // namespace km::servo::detail
