// Which LuGre parameters the reversals determine (feed_drive.h, LugreIdentifiable): a σ below
// a third of the value (or of a scale for values near zero), and for the bristles and the
// Stribeck rise enough samples taken while they act; the others are named in the note with the
// reason and the test that would determine them.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "analysis/servo/feed_drive_detail.h"

namespace km::servo::detail {
namespace {

// Samples in which the friction changes sides after each reversal (median over the windows),
// read from the data: the force (less everything but the bristles) between −0.8 and 0.8 of the
// Coulomb friction, from the sample before the motion turns.
double TransitionSamples(const Strokes& s, const std::vector<Window>& ws,
                         const std::vector<double>& y, double coulomb) {
  std::vector<double> counts;
  std::size_t offset = 0;
  for (const auto& w : ws) {
    const double side = s.v[w.last] > 0.0 ? 1.0 : -1.0;
    std::size_t r = w.first;
    while (r <= w.last && side * s.v[r] <= 0.0) ++r;
    double k = 0.0;
    for (std::size_t i = r > w.first ? r - 1 : r; i <= w.last; ++i)
      if (std::abs(y[offset + i - w.first]) < 0.8 * coulomb) k += 1.0;
    counts.push_back(k);
    offset += w.last - w.first + 1;
  }
  if (counts.empty()) return 0.0;
  std::nth_element(counts.begin(), counts.begin() + static_cast<std::ptrdiff_t>(counts.size() / 2),
                   counts.end());
  return counts[counts.size() / 2];
}

// Samples moving slower than `speed` in each window (median over the windows).
double SlowSamples(const Strokes& s, const std::vector<Window>& ws, double speed) {
  std::vector<double> counts;
  for (const auto& w : ws) {
    double k = 0.0;
    for (std::size_t i = w.first; i <= w.last; ++i)
      if (s.v[i] != 0.0 && std::abs(s.v[i]) < speed) k += 1.0;
    counts.push_back(k);
  }
  if (counts.empty()) return 0.0;
  std::nth_element(counts.begin(), counts.begin() + static_cast<std::ptrdiff_t>(counts.size() / 2),
                   counts.end());
  return counts[counts.size() / 2];
}

std::string Format(double v, int digits = 3) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

}  // namespace

void JudgeLugre(const Strokes& s, const std::vector<Window>& ws, const std::vector<double>& y,
                double top_speed, const FeedDriveResult& r, LugreFit& fit) {
  fit.top_speed = top_speed;
  fit.transition = TransitionSamples(s, ws, y, r.coulomb_N);
  fit.slow = SlowSamples(s, ws, 2.0 * r.lugre->vs_mm_s);
}

void DecideLugre(const LugreFit& fit, FeedDriveResult& r) {
  const double top_speed = fit.top_speed, transition = fit.transition;
  const LugreParameters& p = *r.lugre;
  const LugreParameters& e = *r.lugre_sigma;
  const double critical =
      2.0 * std::sqrt(p.sigma0_N_per_um * 1e6 * std::abs(r.moving_mass_kg)) * 1e-3;  // N·s/mm
  const auto ok = [](double v, double sd, double floor) {
    return std::isfinite(sd) && 3.0 * sd <= std::max(std::abs(v), floor);
  };
  auto& f = r.lugre_identifiable;
  f.Fc_N = ok(p.Fc_N, e.Fc_N, 0.0);
  // The bristles show only in the samples taken while the friction changes sides: fewer than
  // two a reversal, and the fit's σ0 says more about the reading of the motion between samples
  // than about the drive. σ1, and the Stribeck rise that the reversals pass right after the
  // bristles, need σ0 determined first.
  f.sigma0_N_per_um = transition >= 2.0 && ok(p.sigma0_N_per_um, e.sigma0_N_per_um, 0.0);
  f.sigma1_N_s_per_mm =
      f.sigma0_N_per_um && ok(p.sigma1_N_s_per_mm, e.sigma1_N_s_per_mm, 0.1 * critical);
  // The rise is a height F_s − F_c over a width v_s: both are determined only together, and
  // only when the reversals hold samples at speeds below 2 v_s.
  f.Fs_N = f.vs_mm_s = f.sigma0_N_per_um && fit.slow >= 2.0 && ok(p.Fs_N, e.Fs_N, 0.0) &&
                       ok(p.vs_mm_s, e.vs_mm_s, 0.0);
  f.sigma2_N_s_per_mm =
      ok(p.sigma2_N_s_per_mm, e.sigma2_N_s_per_mm, 0.05 * p.Fc_N / std::max(top_speed, 1e-9));
  std::string note;
  const std::string presliding =
      "within the presliding travel after each reversal (2 F_c/σ0, " +
      (f.sigma0_N_per_um ? "≈ " + Format(2.0 * p.Fc_N / p.sigma0_N_per_um) + " µm"
                         : std::string("not determined")) +
      "), while the friction changes sides: these reversals hold " + Format(transition, 2) +
      " samples of that change";
  const std::string finer =
      "Reversals sampled so that the change holds 10 samples or more (a faster sampling, or "
      "micro-strokes shorter than the travel as in the thesis's stop-dwell-go pattern, "
      "recorded at that rate) would identify it.";
  if (!f.sigma0_N_per_um) {
    note += "sigma0_N_per_um is not identifiable: the bristle stiffness shows only " + presliding +
            " (fit: " + Format(p.sigma0_N_per_um) + " ± " + Format(e.sigma0_N_per_um, 2) +
            " N/µm). " + finer;
  }
  if (!f.sigma1_N_s_per_mm) {
    note += std::string(note.empty() ? "" : " ") +
            "sigma1_N_s_per_mm is not identifiable: the micro-damping acts only while the "
            "bristles deflect, " +
            presliding + " (fit: " + Format(p.sigma1_N_s_per_mm) + " ± " +
            Format(e.sigma1_N_s_per_mm, 2) + " N·s/mm). " + finer;
  }
  if (!f.sigma2_N_s_per_mm) {
    note += std::string(note.empty() ? "" : " ") +
            "sigma2_N_s_per_mm is not identifiable: the viscous friction comes from the steady "
            "sliding at the strokes' speeds, and these do not separate it from the Coulomb "
            "friction; strokes at three or more feeds, the fastest several times the slowest, "
            "would identify it.";
  }
  if (!f.Fs_N) {
    note += std::string(note.empty() ? "" : " ") +
            "Fs_N and vs_mm_s are not identifiable: the Stribeck rise of the friction at low "
            "speed (fit: F_s " +
            Format(p.Fs_N) + " ± " + Format(e.Fs_N, 2) + " N over v_s " + Format(p.vs_mm_s) +
            " ± " + Format(e.vs_mm_s, 2) +
            " mm/s) shows only in the few samples of each reversal slower than a few v_s. "
            "Reversals through zero speed with a gentler acceleration or a faster sampling, or "
            "strokes at feeds of the order of v_s, would identify them.";
  }
  const bool lorentzian = p.stribeck_form == LugreParameters::Form::kLorentzian;
  const std::string named =
      lorentzian ? "the Lorentzian g(v) = F_c + (F_s − F_c)/(1 + (v/v_s)²)"
                 : "g(v) = F_c + (F_s − F_c) exp(−|v/v_s|^δ) with δ " + Format(p.stribeck_exponent);
  if (r.lugre_forms_comparable) {
    note += std::string(note.empty() ? "" : " ") +
            "The reversals do not tell the form of the Stribeck rise: exp(−|v/v_s|^δ) and the "
            "Lorentzian 1/(1 + (v/v_s)²) fit them comparably (Δχ² " +
            Format(r.lugre_form_delta_chi2, 2) + "); " + named +
            " is reported, and the σ of F_s, v_s, σ0 and σ1 include the spread between the two "
            "forms.";
  } else if (lorentzian && f.Fs_N) {
    note += std::string(note.empty() ? "" : " ") + "The Stribeck rise is " + named +
            " (Hess and Soom): it fits the reversals clearly better than exp(−|v/v_s|^δ) (Δχ² " +
            Format(-r.lugre_form_delta_chi2, 2) + "); v_s is the speed of that shape.";
  } else if (p.stribeck_exponent != 2.0 && f.Fs_N) {
    note += std::string(note.empty() ? "" : " ") +
            "The Stribeck rise is not Gaussian: g(v) = F_c + (F_s − F_c) exp(−|v/v_s|^δ) with δ " +
            Format(p.stribeck_exponent) + " ± " + Format(e.stribeck_exponent, 2) +
            " fitted (δ = 2 is rejected by the reversals); v_s is the speed of that shape.";
  }
  r.lugre_note = note;
}

}  // namespace km::servo::detail
