// The LuGre fit at the reversals of the feed-drive analysis (feed_drive.h, step 2).
#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/servo/feed_drive_detail.h"

namespace km::servo::detail {
namespace {

struct Window {
  std::size_t first = 0, last = 0;  // inclusive
};

std::vector<Window> Windows(const Strokes& s, double window_mm) {
  std::vector<Window> out;
  for (std::size_t r : s.reversals) {
    const std::size_t seg = s.SegmentOf(r);
    const std::size_t seg_first = seg ? s.segment_end[seg - 1] : 0;
    const std::size_t seg_last = s.segment_end[seg] - 1;
    const double xr = s.x[r];
    Window w{r, r};
    while (w.first > seg_first && std::abs(s.x[w.first - 1] - xr) <= window_mm) --w.first;
    while (w.last < seg_last && std::abs(s.x[w.last + 1] - xr) <= window_mm) ++w.last;
    if (w.last > w.first + 4) out.push_back(w);
  }
  return out;
}

LugreParameters FromLog(const Eigen::Matrix<double, 6, 1>& q) {
  LugreParameters p;
  p.Fc_N = std::exp(q[0]);
  p.Fs_N = std::exp(q[1]);
  p.vs_mm_s = std::exp(q[2]);
  p.sigma0_N_per_um = std::exp(q[3]);
  p.sigma1_N_s_per_mm = std::exp(q[4]);
  p.sigma2_N_s_per_mm = std::exp(q[5]);
  return p;
}

// Model force in every window, starting each from steady sliding at its first sample.
void Predict(const Strokes& s, const std::vector<Window>& ws, const LugreParameters& p,
             std::vector<double>& out) {
  out.clear();
  std::vector<double> t, x;
  for (const auto& w : ws) {
    // A short lead-in at the speed of the first interval puts the bristles in steady state.
    const double dt = s.t[w.first + 1] - s.t[w.first];
    const double dx = s.x[w.first + 1] - s.x[w.first];
    t.assign(1, s.t[w.first] - 200.0 * dt);
    x.assign(1, s.x[w.first] - 200.0 * dx);
    for (std::size_t i = w.first; i <= w.last; ++i) {
      t.push_back(s.t[i]);
      x.push_back(s.x[i]);
    }
    const std::vector<double> f = LugreForce(p, t, x);
    out.insert(out.end(), f.begin() + 1, f.end());
  }
}

// Travel (µm) from each reversal until the friction crosses zero: σ0 ≈ F_c ln 2 / travel.
double SigmaZeroGuess(const Strokes& s, const std::vector<Window>& ws, double coulomb) {
  std::vector<double> guesses;
  for (const auto& w : ws) {
    std::size_t r = w.first;
    while (r <= w.last && std::abs(s.v[r]) > 0.0 &&
           (r == w.first || (s.v[r] > 0) == (s.v[w.first] > 0))) {
      ++r;
    }
    if (r > w.last) continue;
    const double side = s.v[r] > 0.0 ? 1.0 : -1.0;
    for (std::size_t i = r; i <= w.last; ++i) {
      if (side * (s.f[i] - s.position_part[i]) >= 0.0) {
        const double travel = 1e3 * std::abs(s.x[i] - s.x[r]);
        if (travel > 0.0) guesses.push_back(coulomb * std::log(2.0) / travel);
        break;
      }
    }
  }
  if (guesses.empty()) return 1.0;
  std::nth_element(guesses.begin(), guesses.begin() + guesses.size() / 2, guesses.end());
  return guesses[guesses.size() / 2];
}

}  // namespace

void FitLugre(const Strokes& s, const FeedDriveOptions& o, FeedDriveResult& r) {
  const auto ws = Windows(s, o.lugre_window_mm);
  if (ws.empty() || !(r.coulomb_N > 0.0)) {
    r.lugre_note = ws.empty() ? "no reversal with samples either side" : "no positive Coulomb";
    return;
  }
  std::vector<double> y;
  for (const auto& w : ws)
    for (std::size_t i = w.first; i <= w.last; ++i) y.push_back(s.f[i] - s.position_part[i]);
  const std::size_t n = y.size();
  Eigen::Matrix<double, 6, 1> q;
  q << std::log(r.coulomb_N), std::log(1.2 * r.coulomb_N), std::log(1.0),
      std::log(SigmaZeroGuess(s, ws, r.coulomb_N)), std::log(0.01),
      std::log(std::max(r.viscous_N_s_per_mm, 1e-4));
  std::vector<double> model, shifted;
  const auto rss_of = [&](const Eigen::Matrix<double, 6, 1>& qq) {
    Predict(s, ws, FromLog(qq), model);
    double ss = 0.0;
    for (std::size_t i = 0; i < n; ++i) ss += (y[i] - model[i]) * (y[i] - model[i]);
    return ss;
  };
  double rss = rss_of(q), lambda = 1e-2;
  Eigen::MatrixXd jac(n, 6);
  Eigen::Matrix<double, 6, 6> jtj;
  for (int it = 0; it < 40; ++it) {
    Predict(s, ws, FromLog(q), model);
    const std::vector<double> base = model;
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> qk = q;
      qk[k] += 1e-5;
      Predict(s, ws, FromLog(qk), shifted);
      for (std::size_t i = 0; i < n; ++i)
        jac(static_cast<Eigen::Index>(i), k) = (shifted[i] - base[i]) / 1e-5;
    }
    Eigen::VectorXd e(n);
    for (std::size_t i = 0; i < n; ++i) e[static_cast<Eigen::Index>(i)] = y[i] - base[i];
    jtj = jac.transpose() * jac;
    const Eigen::Matrix<double, 6, 1> g = jac.transpose() * e;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::Matrix<double, 6, 6> a = jtj;
      a.diagonal() += lambda * jtj.diagonal().cwiseMax(1e-12);
      const Eigen::Matrix<double, 6, 1> step = a.ldlt().solve(g);
      const Eigen::Matrix<double, 6, 1> qn = q + step.cwiseMax(-2.0).cwiseMin(2.0);
      const double rn = rss_of(qn);
      if (std::isfinite(rn) && rn < rss) {
        improved = true;
        const bool small = rss - rn < 1e-10 * rss;
        q = qn;
        rss = rn;
        lambda = std::max(lambda / 3.0, 1e-9);
        if (small) it = 1000;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  const LugreParameters p = FromLog(q);
  r.lugre = p;
  r.lugre_residual_rms_N = std::sqrt(rss / static_cast<double>(n));
  // Covariance of the logarithms → σ of each parameter (relative σ × value).
  const double s2 = rss / static_cast<double>(n > 6 ? n - 6 : 1);
  const Eigen::Matrix<double, 6, 6> cov =
      s2 * jtj.ldlt().solve(Eigen::Matrix<double, 6, 6>::Identity());
  const auto sd = [&](int k, double v) { return std::sqrt(std::max(0.0, cov(k, k))) * v; };
  LugreParameters ps;
  ps.Fc_N = sd(0, p.Fc_N);
  ps.Fs_N = sd(1, p.Fs_N);
  ps.vs_mm_s = sd(2, p.vs_mm_s);
  ps.sigma0_N_per_um = sd(3, p.sigma0_N_per_um);
  ps.sigma1_N_s_per_mm = sd(4, p.sigma1_N_s_per_mm);
  ps.sigma2_N_s_per_mm = sd(5, p.sigma2_N_s_per_mm);
  r.lugre_sigma = ps;
  // The fit stands only when it agrees with the steady-motion Coulomb friction and the
  // presliding stiffness is determined (the reversals sampled finely enough).
  if (!(p.Fc_N > 0.5 * r.coulomb_N && p.Fc_N < 1.5 * r.coulomb_N) ||
      !(ps.sigma0_N_per_um < 0.5 * p.sigma0_N_per_um)) {
    r.lugre.reset();
    r.lugre_sigma.reset();
    r.lugre_note =
        "the reversals do not determine the LuGre parameters (too few samples within the "
        "presliding travel, or no steady friction either side)";
  }
}

}  // namespace km::servo::detail
