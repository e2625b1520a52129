#include "analysis/servo/feed_drive.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/core/errors.h"
#include "analysis/core/parallel.h"
#include "analysis/servo/feed_drive_detail.h"

namespace km::servo {

void FeedDriveOptions::Check() const {
  if (!(min_speed_fraction > 0.0 && min_speed_fraction < 1.0)) {
    throw InvalidInput("", 0, "min_speed_fraction", "must be in (0, 1)");
  }
  if (!(reversal_skip_mm >= 0.0 && reversal_skip_mm < 1e4)) {
    throw InvalidInput("", 0, "reversal_skip_mm", "must be in [0, 10000) mm");
  }
  if (!(bin_mm > 0.0 && bin_mm < 1e3))
    throw InvalidInput("", 0, "bin_mm", "must be in (0, 1000) mm");
  if (!(max_ripple_components >= 0 && max_ripple_components <= 20)) {
    throw InvalidInput("", 0, "max_ripple_components", "must be in 0 … 20");
  }
  if (!(min_period_mm >= 0.0 && max_period_mm >= 0.0 && min_period_mm < 1e6 &&
        max_period_mm < 1e6)) {
    throw InvalidInput("", 0, "min_period_mm", "periods must be non-negative");
  }
  if (!(lugre_window_mm > 0.0 && lugre_window_mm < 1e3)) {
    throw InvalidInput("", 0, "lugre_window_mm", "must be in (0, 1000) mm");
  }
  const auto positive = [](const std::optional<double>& v, const char* name) {
    if (v && !(*v > 0.0 && *v < 1e9)) throw InvalidInput("", 0, name, "must be positive");
  };
  positive(radius_mm, "radius_mm");
  positive(feed_mm_min, "feed_mm_min");
  positive(kp_per_s, "kp_per_s");
}

std::vector<double> LugreForce(const LugreParameters& p, const std::vector<double>& t_s,
                               const std::vector<double>& x_mm) {
  const std::size_t n = x_mm.size();
  std::vector<double> f(n, 0.0);
  double z = 0.0;  // µm
  for (std::size_t i = 1; i < n; ++i) {
    const double dt = t_s[i] - t_s[i - 1];
    if (!(dt > 0.0)) {
      f[i] = f[i - 1];
      continue;
    }
    const double v = (x_mm[i] - x_mm[i - 1]) / dt;  // mm/s, constant over the interval
    const double vu = 1e3 * v;                      // µm/s
    const double g = detail::StribeckG(p, v);
    const double a = p.sigma0_N_per_um * std::abs(vu) / g;  // 1/s
    if (a > 0.0) {
      const double z_ss = vu / a;
      z = z_ss + (z - z_ss) * std::exp(-a * dt);
    }
    const double zdot = vu - a * z;  // µm/s at the end of the interval
    f[i] = p.sigma0_N_per_um * z + p.sigma1_N_s_per_mm * 1e-3 * zdot + p.sigma2_N_s_per_mm * v;
  }
  if (n > 1) f[0] = f[1];
  return f;
}

double StickMotionUm(const LugreParameters& p, double radius_mm, double feed_mm_min,
                     double kp_per_s) {
  const double d_um = 2.0 * p.Fc_N / p.sigma0_N_per_um;
  const double v = feed_mm_min / 60.0;
  const double t_d = std::sqrt(2.0 * d_um * 1e-3 * radius_mm) / v;
  return d_um / (1.0 + kp_per_s * t_d);
}

FeedDriveResult AnalyzeFeedDrive(const std::vector<double>& t_s, const AxisTrace& axis,
                                 const std::string& file, const FeedDriveOptions& options) {
  ServoFile f;
  f.file = file;
  f.hexapod = false;
  f.t_s = t_s;
  f.axes.push_back(axis);
  return AnalyzeFeedDrive({&f}, axis.axis, options);
}

namespace {

// Widens the σ of Coulomb and viscous friction of a fit with the Stribeck rise `p` taken out
// by how they move when F_s or v_s moves by its σ.
void WidenForStribeck(const detail::Strokes& s, const LugreParameters& p,
                      const LugreParameters& sigma, FeedDriveResult& r) {
  std::vector<std::vector<double>> deltas(2, std::vector<double>(s.x.size()));
  for (int k = 0; k < 2; ++k) {
    LugreParameters q = p;
    if (k == 0) {
      q.Fs_N += sigma.Fs_N;
    } else {
      q.vs_mm_s += sigma.vs_mm_s;
    }
    auto& delta = deltas[static_cast<std::size_t>(k)];
    for (std::size_t i = 0; i < s.x.size(); ++i)
      delta[i] = detail::StribeckRise(q, s.v[i]) - s.Known(i);
  }
  Eigen::Vector2d spread = Eigen::Vector2d::Zero();
  for (const auto& shift : detail::SteadyShifts(s, deltas)) spread += shift.cwiseAbs2();
  r.coulomb_sigma_N = std::hypot(r.coulomb_sigma_N, std::sqrt(spread[0]));
  r.viscous_sigma_N_s_per_mm = std::hypot(r.viscous_sigma_N_s_per_mm, std::sqrt(spread[1]));
}

// The form of the Stribeck rise the reversals support, between the exponential family `r`
// (δ fitted or 2) and the Lorentzian `lorentz`: by their χ² (the weighted residual over the
// better fit's noise of one sample, its correlation included) with 2 a fitted parameter added
// (Akaike). One form is clearly better when the other's exceeds it by more than 9 (3 σ);
// otherwise both fit comparably, the better one is kept and its σ cover the other's values
// (of the LuGre parameters, Coulomb and viscous friction). `r` and `info` become the kept.
void ChooseForm(const FeedDriveResult& lorentz, const detail::LugreFit& lorentz_info,
                FeedDriveResult& r, detail::LugreFit& info) {
  const bool lorentz_lower = lorentz_info.rss < info.rss;
  const double s2 = lorentz_lower ? lorentz_info.s2 : info.s2;
  if (!(s2 > 0.0) || !std::isfinite(lorentz_info.rss)) return;
  const double delta =
      (lorentz_info.rss - info.rss) / s2 + 2.0 * (lorentz_info.params - info.params);
  const bool comparable = std::abs(delta) <= 9.0;
  const FeedDriveResult other = delta < 0.0 ? r : lorentz;
  if (delta < 0.0) {
    r = lorentz;
    info = lorentz_info;
  }
  r.lugre_form_delta_chi2 = delta;
  r.lugre_forms_comparable = comparable;
  if (!comparable) return;
  LugreParameters& e = *r.lugre_sigma;
  const LugreParameters& p = *r.lugre;
  const LugreParameters& q = *other.lugre;
  const auto widen = [](double& sd, double a, double b) { sd = std::hypot(sd, a - b); };
  widen(e.Fs_N, p.Fs_N, q.Fs_N);
  widen(e.vs_mm_s, p.vs_mm_s, q.vs_mm_s);
  widen(e.sigma0_N_per_um, p.sigma0_N_per_um, q.sigma0_N_per_um);
  widen(e.sigma1_N_s_per_mm, p.sigma1_N_s_per_mm, q.sigma1_N_s_per_mm);
  widen(r.coulomb_sigma_N, r.coulomb_N, other.coulomb_N);
  widen(r.viscous_sigma_N_s_per_mm, r.viscous_N_s_per_mm, other.viscous_N_s_per_mm);
  e.Fc_N = r.coulomb_sigma_N;
  e.sigma2_N_s_per_mm = r.viscous_sigma_N_s_per_mm;
}

}  // namespace

FeedDriveResult AnalyzeFeedDrive(const std::vector<const ServoFile*>& files,
                                 const std::string& axis, const FeedDriveOptions& options) {
  options.Check();
  const detail::Strokes collected = detail::CollectStrokes(files, axis, options);
  using Form = LugreParameters::Form;
  // The whole analysis with the Stribeck rise of one form. `first`: the LuGre fit of a first
  // pass, whose Stribeck rise has been taken out of `s`.
  const auto steady_fit = [&](detail::Strokes& s) {
    FeedDriveResult r;
    r.axis = axis;
    r.samples = s.x.size();
    r.reversals = s.reversals.size();
    detail::FitSteady(s, options, r);
    return r;
  };
  // The first steady fit does not depend on the form of the rise: once for both forms.
  detail::Strokes fitted = collected;
  const FeedDriveResult steady = steady_fit(fitted);
  const auto analyse = [&](detail::Strokes& s, const FeedDriveResult* first, Form form,
                           detail::LugreFit& info) {
    FeedDriveResult r = first ? steady_fit(s) : steady;
    if (first) WidenForStribeck(s, *first->lugre, *first->lugre_sigma, r);
    if (options.fit_lugre)
      detail::FitLugre(s, options, r, first ? &*first->lugre : nullptr, form, &info);
    return r;
  };
  // Steady samples slow enough to feel the Stribeck rise (speeds of a few v_s): the rise is
  // taken out and everything fitted once more — when the fit determines F_s and v_s to a third
  // (even if the reversals' samples leave them short of identifiable).
  const auto rise_known = [](const FeedDriveResult& q) {
    return q.lugre && 3.0 * q.lugre_sigma->Fs_N < q.lugre->Fs_N &&
           3.0 * q.lugre_sigma->vs_mm_s < q.lugre->vs_mm_s;
  };
  const auto run = [&](Form form, detail::LugreFit& info) {
    detail::Strokes s = fitted;  // as steady_fit left it
    FeedDriveResult r = analyse(s, nullptr, form, info);
    if (rise_known(r) && detail::SetStribeck(s, *r.lugre)) {
      const FeedDriveResult first = r;
      r = analyse(s, &first, form, info);
    }
    return r;
  };
  // The two forms are independent: analysed side by side. The Lorentzian's (and an error of
  // it) counts only when the exponential form gives a LuGre fit.
  detail::LugreFit info, lorentz_info;
  FeedDriveResult r, lorentz;
  std::exception_ptr lorentz_error;
  ParallelFor(2, [&](std::size_t k) {
    if (k == 0) {
      r = run(Form::kExponential, info);
      return;
    }
    try {
      lorentz = run(Form::kLorentzian, lorentz_info);
    } catch (...) {
      lorentz_error = std::current_exception();
    }
  });
  if (r.lugre) {
    if (lorentz_error) std::rethrow_exception(lorentz_error);
    if (lorentz.lugre) ChooseForm(lorentz, lorentz_info, r, info);
    detail::DecideLugre(info, r);
  }
  if (r.lugre && r.lugre_identifiable.Fc_N && r.lugre_identifiable.sigma0_N_per_um &&
      options.radius_mm && options.feed_mm_min && options.kp_per_s) {
    r.stick_motion_um =
        StickMotionUm(*r.lugre, *options.radius_mm, *options.feed_mm_min, *options.kp_per_s);
  }
  return r;
}

}  // namespace km::servo
