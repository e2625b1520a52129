// Strokes and the steady-motion fit of the feed-drive analysis (feed_drive.h, steps 1).
#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/core/errors.h"
#include "analysis/servo/feed_drive_detail.h"

namespace km::servo::detail {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
// Columns of the steady fit before the ripple: offset, slope, Coulomb, viscous, moving mass.
constexpr int kBase = 5;

struct Component {
  double period = 0.0, a = 0.0, b = 0.0;
};

// Least squares of the columns `cols(i)` (a vector) over the steady samples; returns the
// coefficients and their covariance.
template <typename Cols>
Eigen::VectorXd Solve(const Strokes& s, int p, Cols cols, Eigen::MatrixXd* cov, double* rms) {
  Eigen::MatrixXd ata = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd atb = Eigen::VectorXd::Zero(p);
  std::size_t n = 0;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!s.steady[i]) continue;
    const Eigen::VectorXd c = cols(i);
    ata.noalias() += c * c.transpose();
    atb.noalias() += c * s.f[i];
    ++n;
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(ata);
  const Eigen::VectorXd x = ldlt.solve(atb);
  double ss = 0.0;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!s.steady[i]) continue;
    const double e = s.f[i] - cols(i).dot(x);
    ss += e * e;
  }
  const double dof = static_cast<double>(n > static_cast<std::size_t>(p) ? n - p : 1);
  if (rms) *rms = std::sqrt(ss / static_cast<double>(std::max<std::size_t>(n, 1)));
  if (cov) *cov = (ss / dof) * ldlt.solve(Eigen::MatrixXd::Identity(p, p));
  return x;
}

double Sign(double v) {
  return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
}

// RSS of the best sinusoid of period p (with a constant) through the bins.
double SinusoidRss(const std::vector<double>& xc, const std::vector<double>& y, double p,
                   Component* out) {
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  double yy = 0.0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    const Eigen::Vector3d c(1.0, std::cos(kTwoPi * xc[i] / p), std::sin(kTwoPi * xc[i] / p));
    ata += c * c.transpose();
    atb += c * y[i];
    yy += y[i] * y[i];
  }
  const Eigen::Vector3d x = ata.ldlt().solve(atb);
  if (out) *out = {p, x[1], x[2]};
  return yy - x.dot(atb);
}

// Dominant periods of the binned position-dependent part: periodogram over a geometric grid,
// refined by golden-section search, subtracted, repeated while significant.
std::vector<Component> FindPeriods(const std::vector<double>& xc, std::vector<double> y,
                                   double pmin, double pmax, int max_components) {
  std::vector<Component> found;
  const std::size_t nb = y.size();
  if (nb < 8 || !(pmax > pmin)) return found;
  for (int c = 0; c < max_components; ++c) {
    const int grid = 400;
    double best_p = pmin, best_rss = INFINITY;
    for (int k = 0; k <= grid; ++k) {
      const double p = pmin * std::pow(pmax / pmin, static_cast<double>(k) / grid);
      const double rss = SinusoidRss(xc, y, p, nullptr);
      if (rss < best_rss) {
        best_rss = rss;
        best_p = p;
      }
    }
    const double step = std::pow(pmax / pmin, 1.0 / grid);
    double lo = best_p / step, hi = best_p * step;
    const double g = 0.5 * (std::sqrt(5.0) - 1.0);
    for (int it = 0; it < 60; ++it) {
      const double m1 = hi - g * (hi - lo), m2 = lo + g * (hi - lo);
      if (SinusoidRss(xc, y, m1, nullptr) < SinusoidRss(xc, y, m2, nullptr)) {
        hi = m2;
      } else {
        lo = m1;
      }
    }
    Component comp;
    const double rss = SinusoidRss(xc, y, 0.5 * (lo + hi), &comp);
    const double sigma = std::sqrt(rss / static_cast<double>(nb - 3));
    const double amp = std::hypot(comp.a, comp.b);
    // Significant: the amplitude well above what noise of the bins' spread leaves.
    if (!(amp > 5.0 * sigma * std::sqrt(2.0 / static_cast<double>(nb)))) break;
    for (std::size_t i = 0; i < nb; ++i) {
      y[i] -= comp.a * std::cos(kTwoPi * xc[i] / comp.period) +
              comp.b * std::sin(kTwoPi * xc[i] / comp.period);
    }
    found.push_back(comp);
  }
  return found;
}

}  // namespace

std::size_t Strokes::SegmentOf(std::size_t i) const {
  return static_cast<std::size_t>(std::upper_bound(segment_end.begin(), segment_end.end(), i) -
                                  segment_end.begin());
}

Strokes CollectStrokes(const std::vector<const ServoFile*>& files, const std::string& axis,
                       const FeedDriveOptions& o) {
  Strokes s;
  std::size_t forward = 0, backward = 0;
  for (const ServoFile* file : files) {
    const AxisTrace* tr = nullptr;
    for (const auto& a : file->axes)
      if (a.axis == axis) tr = &a;
    if (!tr) throw InvalidInput(file->file, 0, "axis", "the record has no axis " + axis);
    const std::size_t n = tr->pos_mm.size(), first = s.x.size();
    double vmax = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t a = i ? i - 1 : 0, b = i + 1 < n ? i + 1 : n - 1;
      const double dt = file->t_s[b] - file->t_s[a];
      const double v = dt > 0.0 ? (tr->pos_mm[b] - tr->pos_mm[a]) / dt : 0.0;
      s.t.push_back(file->t_s[i]);
      s.x.push_back(tr->pos_mm[i]);
      s.v.push_back(v);
      s.f.push_back(tr->force_N[i]);
      vmax = std::max(vmax, std::abs(v));
    }
    double last_sign = 0.0, reversal_x = 0.0;
    for (std::size_t i = first; i < s.x.size(); ++i) {
      const double sg = std::abs(s.v[i]) > 1e-9 * vmax ? Sign(s.v[i]) : 0.0;
      if (sg != 0.0 && sg != last_sign) {
        if (last_sign != 0.0) s.reversals.push_back(i);
        last_sign = sg;
        reversal_x = s.x[i];
      }
      const bool st = last_sign != 0.0 && std::abs(s.v[i]) >= o.min_speed_fraction * vmax &&
                      std::abs(s.x[i] - reversal_x) >= o.reversal_skip_mm;
      s.steady.push_back(st);
      if (st) (s.v[i] > 0.0 ? forward : backward)++;
    }
    for (std::size_t i = first; i < s.x.size(); ++i) {  // second differences, mm/s²
      const std::size_t c = std::clamp(i, first + 1, std::max(first + 1, s.x.size() - 2));
      const double h1 = s.t[c] - s.t[c - 1], h2 = s.t[c + 1] - s.t[c];
      s.a.push_back(h1 > 0.0 && h2 > 0.0
                        ? 2.0 * ((s.x[c + 1] - s.x[c]) / h2 - (s.x[c] - s.x[c - 1]) / h1) /
                              (h1 + h2)
                        : 0.0);
    }
    s.segment_end.push_back(s.x.size());
  }
  if (forward < 10 || backward < 10) {
    throw InvalidInput(files.empty() ? "" : files.front()->file, 0, "pos_mm",
                       "the strokes need steady motion in both directions (found " +
                           std::to_string(forward) + " forward and " + std::to_string(backward) +
                           " backward samples)");
  }
  return s;
}

void FitSteady(Strokes& s, const FeedDriveOptions& o, FeedDriveResult& r) {
  // 1. Without the ripple: offset, slope, Coulomb, viscous.
  const auto base = [&](std::size_t i) {
    Eigen::VectorXd c(kBase);
    c << 1.0, s.x[i], Sign(s.v[i]), s.v[i], 1e-3 * s.a[i];
    return c;
  };
  const Eigen::VectorXd b0 = Solve(s, kBase, base, nullptr, nullptr);
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
    sum[b] += s.f[i] - base(i).dot(b0);
    cnt[b] += 1.0;
  }
  std::vector<double> xc, y;
  for (std::size_t b = 0; b < nb; ++b) {
    if (cnt[b] == 0.0) continue;
    xc.push_back(xmin + (static_cast<double>(b) + 0.5) * o.bin_mm);
    y.push_back(sum[b] / cnt[b]);
  }
  const double pmin = o.min_period_mm > 0.0 ? o.min_period_mm : 4.0 * o.bin_mm;
  const double pmax = o.max_period_mm > 0.0 ? o.max_period_mm : (xmax - xmin) / 2.0;
  std::vector<Component> comps = FindPeriods(xc, y, pmin, pmax, o.max_ripple_components);
  // 3. Everything together; Gauss–Newton on the periods (columns ∂/∂P).
  const int nc = static_cast<int>(comps.size());
  const int p = kBase + 3 * nc;
  Eigen::VectorXd x;
  Eigen::MatrixXd cov;
  double rms = 0.0;
  for (int it = 0; it < 4; ++it) {
    const auto cols = [&](std::size_t i) {
      Eigen::VectorXd c(p);
      c.head<kBase>() = base(i);
      for (int k = 0; k < nc; ++k) {
        const double w = kTwoPi * s.x[i] / comps[k].period;
        c[kBase + 3 * k] = std::cos(w);
        c[kBase + 1 + 3 * k] = std::sin(w);
        // ∂/∂P of a cos w + b sin w, w = 2πx/P.
        c[kBase + 2 + 3 * k] =
            (w / comps[k].period) * (comps[k].a * std::sin(w) - comps[k].b * std::cos(w));
      }
      return c;
    };
    x = Solve(s, p, cols, &cov, &rms);
    for (int k = 0; k < nc; ++k) {
      comps[k].a = x[kBase + 3 * k];
      comps[k].b = x[kBase + 1 + 3 * k];
      // A Gauss–Newton step on the period, at most 2 % at a time.
      const double step = x[kBase + 2 + 3 * k], limit = 0.02 * comps[k].period;
      comps[k].period += std::clamp(step, -limit, limit);
    }
  }
  r.offset_N = x[0];
  r.slope_N_per_mm = x[1];
  r.coulomb_N = x[2];
  r.coulomb_sigma_N = std::sqrt(cov(2, 2));
  r.viscous_N_s_per_mm = x[3];
  r.viscous_sigma_N_s_per_mm = std::sqrt(cov(3, 3));
  r.moving_mass_kg = x[4];
  r.residual_rms_N = rms;
  for (std::size_t i = 0; i < s.x.size(); ++i) r.steady_samples += s.steady[i];
  for (int k = 0; k < nc; ++k) {
    const int ia = kBase + 3 * k, ib = ia + 1;
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
  // Reported: components above 4 σ of their amplitude and 5 % of the largest (the others stay
  // in the fit, where they cost nothing).
  const double largest = r.ripple.empty() ? 0.0 : r.ripple.front().amplitude_N;
  std::erase_if(r.ripple, [&](const Ripple& q) {
    return !(q.amplitude_N > 4.0 * q.amplitude_sigma_N && q.amplitude_N >= 0.05 * largest);
  });
  s.position_part.resize(s.x.size());
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    double v = x[0] + x[1] * s.x[i];
    for (int k = 0; k < nc; ++k) {
      const double w = kTwoPi * s.x[i] / comps[k].period;
      v += comps[k].a * std::cos(w) + comps[k].b * std::sin(w);
    }
    s.position_part[i] = v;
  }
}

}  // namespace km::servo::detail
