// The LuGre fit at the reversals of the feed-drive analysis (feed_drive.h, step 2).
//
// Around every reversal (1 mm either side) the force less its position-dependent part, its
// viscous part σ2 v and its inertia m a is the bristle force σ0 z + σ1 dz/dt of eqs. 4.1–4.2,
// with F_c and σ2 those of the steady sliding (F = ±g(v) + σ2 v, g → F_c above a few v_s) and m
// the steady fit's. z is integrated along the measured motion: the speed at each sample by
// central differences (zero next to a standstill), linear between samples with the measured
// travel, exact exponential steps of eq. 4.1 on sub-intervals of constant speed. Samples where
// the acceleration changes weigh less (their inertia is uncertain) and a standstill counts as
// one sample. Levenberg–Marquardt on ln F_s, ln v_s, ln σ0 and σ1 itself (the force is linear in
// σ1, which may be zero; the other derivatives carried through the steps, feed_drive_bristles.cpp),
// from six starts, with the Gaussian rise (δ = 2); then once more with
// the rise's exponent δ free (ln δ in [ln 0.5, ln 6]), from δ = 2 and δ = 1. The thesis leaves
// g(v) open, and a rise of another shape fitted as a Gaussian gives a v_s tens of σ off with a
// tiny σ. The fitted δ is kept where the records reject δ = 2 by more than 3 σ; otherwise δ = 2,
// each parameter's σ including its change when δ is fitted. With the Lorentzian rise
// 1/(1 + (v/v_s)²) (feed_drive.cpp compares the forms) only the fit with δ held runs. The σ of each
// parameter is the statistical one (the residual's own scatter, inflated by its correlation from
// sample to sample; infinite along directions the data leave flat) and, added in quadrature, its
// change when the motion between samples is read at constant speed: where a reversal passes between
// few samples that second term dominates. feed_drive_lugre_judge.cpp then decides which
// parameters are determined.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include "analysis/core/parallel.h"
#include "analysis/servo/feed_drive_detail.h"

namespace km::servo::detail {
namespace {

constexpr int kParams = 5;  // ln F_s, ln v_s, ln σ0, σ1, ln δ
constexpr int kExponent = 4;
using Vec = Eigen::Matrix<double, kParams, 1>;
using Mat = Eigen::Matrix<double, kParams, kParams>;

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
    if (w.last > w.first + 4 && s.v[w.first] != 0.0) out.push_back(w);
  }
  return out;
}

// F_c and σ2 come from the steady sliding (F = ±g(v) + σ2 v, g → F_c well above v_s).
struct Sliding {
  double Fc_N = 0.0, sigma2_N_s_per_mm = 0.0;
  LugreParameters::Form form = LugreParameters::Form::kExponential;
};

LugreParameters FromVec(const Vec& q, const Sliding& sliding) {
  LugreParameters p;
  p.Fc_N = sliding.Fc_N;
  p.Fs_N = std::exp(q[0]);
  p.vs_mm_s = std::exp(q[1]);
  p.sigma0_N_per_um = std::exp(q[2]);
  p.sigma1_N_s_per_mm = q[3];
  p.sigma2_N_s_per_mm = sliding.sigma2_N_s_per_mm;
  p.stribeck_exponent = std::exp(q[kExponent]);
  p.stribeck_form = sliding.form;
  return p;
}

// Travel (µm) from each reversal until the friction crosses zero: σ0 ≈ F_c ln 2 / travel.
double SigmaZeroGuess(const Strokes& s, const std::vector<Window>& ws, const std::vector<double>& y,
                      double coulomb) {
  std::vector<double> guesses;
  std::size_t offset = 0;
  for (const auto& w : ws) {
    const double side = s.v[w.last] > 0.0 ? 1.0 : -1.0;  // the new direction
    std::size_t r = w.first;
    while (r <= w.last && side * s.v[r] <= 0.0) ++r;  // first sample moving the new way
    for (std::size_t i = r; i <= w.last; ++i) {
      if (side * y[offset + i - w.first] >= 0.0) {
        const double travel = 1e3 * std::abs(s.x[i] - s.x[r > w.first ? r - 1 : r]);
        if (travel > 0.0) guesses.push_back(coulomb * std::log(2.0) / travel);
        break;
      }
    }
    offset += w.last - w.first + 1;
  }
  if (guesses.empty()) return 1.0;
  std::nth_element(guesses.begin(),
                   guesses.begin() + static_cast<std::ptrdiff_t>(guesses.size() / 2),
                   guesses.end());
  return guesses[guesses.size() / 2];
}

struct Fit {
  Vec q = Vec::Zero();
  Mat jtj = Mat::Zero();
  double rss = INFINITY;
  bool free_exponent = false;
  bool converged = false;  // ended at a minimum (not at its iteration limit)
  bool joined = false;     // stopped in the valley of an earlier fit (Solve's `valleys`)
  std::vector<double> e;   // weighted residual √w (y − model) at q
};

// Whether q lies in the valley of the converged fit a: within one σ of it in its covariance,
// (q − q_a)ᵀ JᵀJ (q − q_a) ≤ s², s² a's residual over its n samples. From there the fit ends
// at a's minimum (its quadratic model holds far beyond one σ).
bool InValley(const Fit& a, const Vec& q, std::size_t n) {
  const int m = a.free_exponent ? kParams : kExponent;
  const double s2 = a.rss / std::max(static_cast<double>(n) - m, 1.0);
  const Eigen::VectorXd d = (q - a.q).head(m);
  return a.converged && d.dot(a.jtj.topLeftCorner(m, m) * d) <= s2;
}

// The range of the Stribeck exponent δ fitted (ln δ clamped to it).
constexpr double kMinExponent = 0.5, kMaxExponent = 6.0;

// Whether the fit at fit.q (its normal matrix fit.jtj, gradient g = Jᵀ √w e) is within 10⁻⁴ of
// every parameter's σ of the optimum of its Gauss–Newton model: the step left, measured in the
// parameters' covariance s² (JᵀJ)⁻¹, is √(gᵀ (JᵀJ)⁻¹ g / s²) and bounds each parameter's step
// over its σ. s² is the residual over all the n samples: smaller than the noise the reported σ
// are computed with (fewer independent samples, their correlation), so those σ are wider still.
// Where the data leave a direction flat (a parameter of infinite σ, as δ often is) the fit
// would otherwise crawl along it with rss falling by a few 10⁻¹⁰ an iteration.
bool Converged(const Fit& fit, const Vec& g, bool free_exponent, std::size_t n) {
  constexpr double kTolerance = 1e-4;
  const int m = free_exponent ? kParams : kExponent;
  const double s2 = fit.rss / std::max(static_cast<double>(n) - m, 1.0);
  Mat a = fit.jtj;
  a.diagonal() += 1e-12 * fit.jtj.diagonal().cwiseMax(1e-300);
  if (!free_exponent) a(kExponent, kExponent) = 1.0;
  const double left = g.dot(a.ldlt().solve(g));
  return std::isfinite(left) && left < kTolerance * kTolerance * s2;
}

// The normal equations JᵀW J and Jᵀ W (y − model) of the fit, summed row by row (the force is
// linear in σ1: its column is the damping). The samples of a standstill share one row (the
// bristle force holds): a run of equal rows is summed once with the run's weights.
void NormalEquations(const std::vector<BristleDerivatives>& derivatives,
                     const std::vector<double>& damping, const std::vector<double>& y,
                     const std::vector<double>& model, const std::vector<double>& w, bool exponent,
                     Mat& jtj, Vec& g) {
  jtj.setZero();
  g.setZero();
  Vec run = Vec::Zero();
  double run_w = 0.0, run_wr = 0.0;  // Σ w and Σ w (y − model) over the run of `run`
  const auto flush = [&] {
    jtj.noalias() += run_w * run * run.transpose();
    g += run_wr * run;
  };
  for (std::size_t i = 0; i < y.size(); ++i) {
    Vec row;
    row << derivatives[i][0], derivatives[i][1], derivatives[i][2], damping[i],
        exponent ? derivatives[i][3] : 0.0;
    if (i == 0 || row != run) {
      if (i > 0) flush();
      run = row;
      run_w = run_wr = 0.0;
    }
    run_w += w[i];
    run_wr += w[i] * (y[i] - model[i]);
  }
  if (!y.empty()) flush();
}

// Levenberg–Marquardt from q0 on the windows' target force y; δ held at q0's unless
// `free_exponent`. With `valleys` (fits of the same problem), the fit stops as `joined` once
// it enters the valley of one of them.
Fit Solve(const Strokes& s, const std::vector<Window>& ws, const std::vector<double>& y,
          const std::vector<double>& w, const Sliding& sliding, Reading reading, const Vec& q0,
          bool free_exponent, int iterations = 60, const std::vector<Fit>* valleys = nullptr) {
  const std::size_t n = y.size();
  // The force, damping and derivatives at fit.q throughout. Every trial computes its
  // derivatives too (the force is the same bit for bit with and without them), so an accepted
  // trial brings the next iteration's Jacobian along instead of a pass of its own.
  std::vector<double> model, shifted, damping, trial_damping;
  std::vector<BristleDerivatives> derivatives, trial_derivatives;
  const BristlePath path(s, ws, reading);
  const auto residual = [&](const Vec& q, std::vector<double>& m, std::vector<double>& d,
                            std::vector<BristleDerivatives>& dq) {
    BristleForce(s, ws, path, FromVec(q, sliding), m, &d, &dq, free_exponent);
    double ss = 0.0;
    for (std::size_t i = 0; i < n; ++i) ss += w[i] * (y[i] - m[i]) * (y[i] - m[i]);
    return ss;
  };
  Fit fit;
  fit.q = q0;
  fit.free_exponent = free_exponent;
  fit.rss = residual(fit.q, model, damping, derivatives);
  double lambda = 1e-2;
  for (int it = 0; it < iterations; ++it) {
    Vec g;
    NormalEquations(derivatives, damping, y, model, w, free_exponent, fit.jtj, g);
    if (Converged(fit, g, free_exponent, n)) {
      fit.converged = true;
      break;
    }
    if (valleys && std::any_of(valleys->begin(), valleys->end(),
                               [&](const Fit& v) { return InValley(v, fit.q, n); })) {
      fit.joined = true;
      break;
    }
    bool improved = false, small = false;
    for (int tries = 0; tries < 12 && !improved; ++tries) {
      Mat a = fit.jtj;
      a.diagonal() += lambda * fit.jtj.diagonal().cwiseMax(1e-12);
      if (!free_exponent) a(kExponent, kExponent) = 1.0;
      Vec step = a.ldlt().solve(g);
      step.head<3>() = step.head<3>().cwiseMax(-2.0).cwiseMin(2.0);
      step[kExponent] = free_exponent ? std::clamp(step[kExponent], -0.5, 0.5) : 0.0;
      Vec qn = fit.q + step;
      qn[kExponent] = std::clamp(qn[kExponent], std::log(kMinExponent), std::log(kMaxExponent));
      const double rn = residual(qn, shifted, trial_damping, trial_derivatives);
      if (std::isfinite(rn) && rn < fit.rss) {
        improved = true;
        std::swap(model, shifted);
        std::swap(damping, trial_damping);
        std::swap(derivatives, trial_derivatives);
        small = fit.rss - rn < 1e-10 * fit.rss;
        fit.q = qn;
        fit.rss = rn;
        lambda = std::max(lambda / 3.0, 1e-9);
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved || small) {
      fit.converged = true;
      break;
    }
  }
  fit.e.resize(n);
  for (std::size_t i = 0; i < n; ++i) fit.e[i] = std::sqrt(w[i]) * (y[i] - model[i]);
  return fit;
}

// How much the residual's correlation from sample to sample inflates a variance computed as if
// the samples were independent: 1 + 2 Σ ρ_k over the lags k until the correlation ρ_k of the
// residual with itself k samples later (within a window) stops being positive (at least 1). A
// model that misses the drive's friction leaves residuals that run in long waves: each sample
// then tells less than the noise suggests.
double CorrelationFactor(const std::vector<Window>& ws, const std::vector<double>& e) {
  constexpr std::size_t kMaxLag = 50;
  double c0 = 0.0;
  for (double v : e) c0 += v * v;
  if (!(c0 > 0.0)) return 1.0;
  double factor = 1.0;
  for (std::size_t lag = 1; lag <= kMaxLag; ++lag) {
    double c = 0.0;
    std::size_t offset = 0;
    for (const auto& w : ws) {
      const std::size_t len = w.last - w.first + 1;
      for (std::size_t i = offset; i + lag < offset + len; ++i) c += e[i] * e[i + lag];
      offset += len;
    }
    if (!(c > 0.0)) break;
    factor += 2.0 * c / c0;
  }
  return factor;
}

// σ of ln F_s, ln v_s, ln σ0, σ1 and ln δ (0 when held): the statistical one (the weighted
// residual's own scatter, inflated by its correlation; a direction the data leave flat has an
// infinite σ) and the change under the other reading of the motion, added in quadrature.
Vec Uncertainty(const Fit& fit, const Fit& other, const std::vector<Window>& ws, double n) {
  const int m = fit.free_exponent ? kParams : kExponent;
  const double s2 = fit.rss / std::max(n - m, 1.0) * CorrelationFactor(ws, fit.e);
  Vec scale = Vec::Zero();
  for (int k = 0; k < m; ++k) scale[k] = fit.jtj(k, k) > 0.0 ? 1.0 / std::sqrt(fit.jtj(k, k)) : 0.0;
  const Eigen::MatrixXd c = (scale.asDiagonal() * fit.jtj * scale.asDiagonal()).topLeftCorner(m, m);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(c);
  const double top = eig.eigenvalues().maxCoeff();
  Vec sd = Vec::Zero();
  for (int k = 0; k < m; ++k) {
    double var = 0.0;
    for (int j = 0; j < m; ++j) {
      const double vkj = eig.eigenvectors()(k, j), lambda = eig.eigenvalues()[j];
      if (lambda > 1e-12 * top) {
        var += vkj * vkj / lambda;
      } else if (std::abs(vkj) > 1e-6) {
        var = INFINITY;
      }
    }
    if (!(scale[k] > 0.0)) var = INFINITY;
    const double d = std::isfinite(other.rss) ? other.q[k] - fit.q[k] : 0.0;
    sd[k] = std::sqrt(s2 * var * scale[k] * scale[k] + d * d);
    if (!std::isfinite(var)) sd[k] = INFINITY;
  }
  return sd;
}

// The windows' force less everything but the bristles (position part, viscous part, inertia)
// and the weight of each sample; `independent` the samples counted as independent.
void Targets(const Strokes& s, const std::vector<Window>& ws, const FeedDriveResult& r,
             double top_speed, std::vector<double>& y, std::vector<double>& wt,
             double& independent) {
  for (const auto& w : ws) {
    for (std::size_t i = w.first; i <= w.last; ++i) {
      y.push_back(s.f[i] - s.position_part[i] - r.viscous_N_s_per_mm * s.v[i] -
                  r.moving_mass_kg * 1e-3 * s.a[i]);
      wt.push_back(s.Weight(i, r.moving_mass_kg));
    }
  }
  // A standstill counts as one sample: its samples repeat one frozen bristle state, whose
  // error (it depends on the last instants of the motion, between samples) is common to them.
  std::size_t k = 0;
  independent = 0.0;
  for (const auto& w : ws) {
    for (std::size_t i = w.first; i <= w.last;) {
      std::size_t j = i;
      while (j <= w.last && std::abs(s.v[j]) < 1e-3 * top_speed) ++j;
      for (std::size_t q = i; q < j; ++q) wt[k + q - w.first] /= static_cast<double>(j - i);
      independent += 1.0;
      i = j > i ? j : i + 1;
    }
    k += w.last - w.first + 1;
  }
}

}  // namespace

void FitLugre(const Strokes& s, const FeedDriveOptions& o, FeedDriveResult& r,
              const LugreParameters* start, LugreParameters::Form form, LugreFit* info) {
  const auto ws = Windows(s, o.lugre_window_mm);
  if (ws.empty() || !(r.coulomb_N > 0.0)) {
    r.lugre_note = ws.empty() ? "no reversal with samples either side" : "no positive Coulomb";
    return;
  }
  double top_speed = 0.0;
  for (std::size_t i = 0; i < s.v.size(); ++i)
    if (s.steady[i]) top_speed = std::max(top_speed, std::abs(s.v[i]));
  std::vector<double> y, wt;
  double independent = 0.0;
  Targets(s, ws, r, top_speed, y, wt, independent);
  const Sliding sliding{r.coulomb_N, r.viscous_N_s_per_mm, form};
  const bool lorentzian = form == LugreParameters::Form::kLorentzian;
  const double sigma0 = SigmaZeroGuess(s, ws, y, r.coulomb_N);
  const double critical = 2.0 * std::sqrt(sigma0 * 1e6 * std::abs(r.moving_mass_kg)) * 1e-3;
  const auto guess = [&](double fs, double vs, double s0, double s1, double delta) {
    Vec q0;
    q0 << std::log(fs), std::log(vs), std::log(s0), s1, std::log(delta);
    return q0;
  };
  // The Gaussian rise (δ = 2; or the Lorentzian) first: from a fit of the same reversals
  // before, or from six starts of the Stribeck speed and the damping, the best carried on.
  Fit gauss;
  if (start) {
    gauss = Solve(
        s, ws, y, wt, sliding, Reading::kLinear,
        guess(start->Fs_N, start->vs_mm_s, start->sigma0_N_per_um, start->sigma1_N_s_per_mm, 2.0),
        false);
  } else {
    // Six starts, one after the other: a start that enters the valley of an earlier one's
    // minimum stops there (it would end at that minimum). The best end is carried on.
    constexpr double kSpeeds[] = {0.3, 1.0, 3.0};
    std::vector<Fit> ends;
    for (std::size_t k = 0; k < 6; ++k) {
      const Fit f = Solve(
          s, ws, y, wt, sliding, Reading::kLinear,
          guess(1.2 * r.coulomb_N, kSpeeds[k / 2], sigma0, k % 2 == 0 ? 0.0 : 0.5 * critical, 2.0),
          false, 12, &ends);
      if (!f.joined) ends.push_back(f);
    }
    for (const Fit& f : ends)
      if (f.rss < gauss.rss) gauss = f;
    gauss = Solve(s, ws, y, wt, sliding, Reading::kLinear, gauss.q, false);
  }
  // Then the shape of the rise itself, from the Gaussian fit with δ = 2 and δ = 1 (and the
  // earlier fit's δ); the Lorentzian has none.
  Fit shaped;
  std::vector<double> deltas{2.0, 1.0};
  if (lorentzian) deltas.clear();
  if (start && start->stribeck_exponent != 2.0) deltas.push_back(start->stribeck_exponent);
  // The fits of the shape one after the other (one that enters the valley of an earlier one's
  // minimum stops there), beside the Gaussian one under the other reading of the motion.
  std::vector<Fit> shapes;
  Fit other;
  ParallelFor(2, [&](std::size_t k) {
    if (k == 1) {
      other = Solve(s, ws, y, wt, sliding, Reading::kConstant, gauss.q, false);
      return;
    }
    for (double delta : deltas) {
      Vec q0 = gauss.q;
      q0[kExponent] = std::log(delta);
      const Fit f = Solve(s, ws, y, wt, sliding, Reading::kLinear, q0, true, 60, &shapes);
      if (!f.joined) shapes.push_back(f);
    }
  });
  for (const Fit& f : shapes)
    if (f.rss < shaped.rss) shaped = f;
  const Vec sd_gauss = Uncertainty(gauss, other, ws, independent);
  const Vec sd_shaped =
      lorentzian
          ? Vec::Zero().eval()
          : Uncertainty(shaped, Solve(s, ws, y, wt, sliding, Reading::kConstant, shaped.q, true),
                        ws, independent);
  // The fitted shape is taken where the records reject the Gaussian (δ more than 3 σ from 2);
  // otherwise the Gaussian, each parameter's σ including its change when δ is fitted.
  const bool rejects = !lorentzian && std::isfinite(sd_shaped[kExponent]) &&
                       std::abs(shaped.q[kExponent] - std::log(2.0)) > 3.0 * sd_shaped[kExponent];
  const Fit& best = rejects ? shaped : gauss;
  Vec sd = rejects ? sd_shaped : sd_gauss;
  if (!rejects && !lorentzian) {
    for (int k = 0; k < kExponent; ++k) sd[k] = std::hypot(sd[k], shaped.q[k] - gauss.q[k]);
  }
  sd[kExponent] = sd_shaped[kExponent];
  const LugreParameters p = FromVec(best.q, sliding);
  double weights = 0.0;
  for (double w : wt) weights += w;
  r.lugre_residual_rms_N = std::sqrt(best.rss / std::max(weights, 1e-300));
  LugreParameters ps;
  ps.Fc_N = r.coulomb_sigma_N;
  ps.Fs_N = sd[0] * p.Fs_N;
  ps.vs_mm_s = sd[1] * p.vs_mm_s;
  ps.sigma0_N_per_um = sd[2] * p.sigma0_N_per_um;
  ps.sigma1_N_s_per_mm = sd[3];
  ps.sigma2_N_s_per_mm = r.viscous_sigma_N_s_per_mm;
  ps.stribeck_exponent = sd[kExponent] * p.stribeck_exponent;
  r.lugre = p;
  r.lugre_sigma = ps;
  LugreFit fit;
  fit.rss = best.rss;
  fit.params = best.free_exponent ? kParams : kExponent;
  fit.s2 = best.rss / std::max(independent - fit.params, 1.0) * CorrelationFactor(ws, best.e);
  JudgeLugre(s, ws, y, top_speed, r, fit);
  DecideLugre(fit, r);
  if (info) *info = fit;
}

}  // namespace km::servo::detail
