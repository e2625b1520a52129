// Entries of the DBB diagnosis (diagnosis_entry.h): a fitted candidate's reported values,
// uncertainties, spike figures, contributions and the naming rule.
#include "analysis/dbb/diagnosis_entry.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "analysis/core/angles.h"
#include "analysis/core/extremes.h"

namespace km::dbb::diag {

using Eigen::VectorXd;
using serial_effects::EffectId;

// |value| / σ, finite also for noise-free data (σ = 0).
double ZScore(double value, double sigma) {
  if (sigma > 0.0) return std::min(std::abs(value) / sigma, 1e9);
  return value != 0.0 ? 1e9 : 0.0;
}

namespace {

// Smallest and largest of v over [b, e) (b < e).
std::pair<double, double> Extremes(const VectorXd& v, std::size_t b, std::size_t e) {
  return km::Extremes(v.data() + b, e - b);
}

double Range(const VectorXd& v, std::size_t b, std::size_t e) {
  const auto [mn, mx] = Extremes(v, b, e);
  return mx - mn;
}

// Range of x·a over [b, e) without forming x·a: a product rounds monotonically in a, so its
// largest and smallest values are those of a's extremes (swapped for x < 0) — the same value.
double ScaledRange(const VectorXd& a, double x, std::size_t b, std::size_t e) {
  const auto [mn, mx] = Extremes(a, b, e);
  if (!std::isfinite(mx - mn) || !std::isfinite(x)) {
    const VectorXd xa = x * a;
    return Range(xa, b, e);
  }
  return x >= 0.0 ? x * mx - x * mn : x * mn - x * mx;
}

}  // namespace

// A reversal spike's decay shape, its width in time (the decay constant τ of an exponential
// decay; the standard width of a Gaussian-like one): width_deg · π/180 · R / V, with R and V the
// first trace's radius and feed (a pair runs both at one feed), and the doubt about the decay
// shape added to the height's uncertainty.
void AddSpikeFigures(const Problem& p, const Candidate& c, DiagnosisEntry& en) {
  en.shape_kind = c.shape.size() > 1 && c.shape[1] == 2.0 ? "gaussian" : "exponential";
  if (p.ctx[0].SpeedMmPerS() > 0.0) {
    const double s_per_deg = kDeg * p.ctx[0].radius_mm / p.ctx[0].SpeedMmPerS();
    en.shape["width_s"] = en.shape.at("width_deg") * s_per_deg;
    const auto u = en.shape_uncertainty.find("width_deg");
    if (u != en.shape_uncertainty.end()) en.shape_uncertainty["width_s"] = u->second * s_per_deg;
  }
  if (c.shape_doubt_var > 0.0) {
    en.uncertainty[0] = std::sqrt(en.uncertainty[0] * en.uncertainty[0] + c.shape_doubt_var);
    en.significance = ZScore(en.value[0], en.uncertainty[0]);
  }
}

// Entry of a fitted candidate: value, uncertainty, contributions.
DiagnosisEntry MakeEntry(const Problem& p, const Candidate& c, const FitResult& f, std::size_t j,
                         char first, char second) {
  const auto& info = serial_effects::Info(c.id);
  DiagnosisEntry en;
  en.id = c.id;
  en.effect = serial_effects::EffectName(c.id, first, second);
  en.unit = info.unit;
  const int nl = info.num_linear;
  const int off = f.first_col[j];
  EffectEstimate est = EstimateEffect(p, c.id, c.shape, f.x, f.cov, off);
  en.params = std::move(est.params);
  en.value = std::move(est.value);
  en.uncertainty = std::move(est.sigma);
  en.significance = est.z;
  for (std::size_t k = 0; k < c.shape.size(); ++k)
    en.shape[info.param_names[static_cast<std::size_t>(nl) + k]] = c.shape[k];
  const auto sh = f.shape_sigma.find(static_cast<int>(j));
  if (sh != f.shape_sigma.end()) {
    en.shape_uncertainty[info.param_names[static_cast<std::size_t>(nl)]] = sh->second;
  }
  if (IsSpike(c.id)) AddSpikeFigures(p, c, en);
  if (nl == 1) {
    const VectorXd& a = *f.a[static_cast<std::size_t>(off)];
    for (int t = 0; t < p.traces; ++t)
      en.peak_to_valley_um.push_back(ScaledRange(a, f.x[off], p.begin[t], p.begin[t + 1]));
    return en;
  }
  const VectorXd sig = f.Combine(off, nl, p.n);
  for (int t = 0; t < p.traces; ++t)
    en.peak_to_valley_um.push_back(Range(sig, p.begin[t], p.begin[t + 1]));
  return en;
}

// contribution_pct of each entry on trace t: its own peak-to-valley over the sum of all the
// entries' peak-to-valley values plus the range of what is left unexplained.
void Normalise(const Problem& p, std::vector<DiagnosisEntry*> entries, const VectorXd& residual) {
  for (int t = 0; t < p.traces; ++t) {
    double total = Range(residual, p.begin[t], p.begin[t + 1]);
    for (const auto* e : entries) total += e->peak_to_valley_um[static_cast<std::size_t>(t)];
    for (auto* e : entries) {
      e->contribution_pct.resize(static_cast<std::size_t>(p.traces), 0.0);
      e->contribution_pct[static_cast<std::size_t>(t)] =
          total > 0.0 ? 100.0 * e->peak_to_valley_um[static_cast<std::size_t>(t)] / total : 0.0;
    }
  }
}

// z + 1 for two-value effects and for effects whose shape was searched (one more fitted
// value, and a search that would otherwise make features out of noise).
// A stick-slip sawtooth is a slow ramp against the motion and a sudden slip: fitted reversed
// (amplitude < 0) it is not that shape, and it is not named.
bool Significant(const DiagnosisEntry& e, const DiagnosisOptions& o) {
  const bool strict =
      e.value.size() > 1 || e.params.size() > 1 + e.shape.size() || HasFittedShape(e.id);
  if (e.id == EffectId::kStickSlip && !(e.value[0] > 0.0)) return false;
  return e.significance > (strict ? o.significance + 1.0 : o.significance);
}

}  // namespace km::dbb::diag
