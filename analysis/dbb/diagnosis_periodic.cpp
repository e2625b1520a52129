// Stick-slip and cyclic errors of the serial-machine diagnosis (diagnosis_run.h): whether
// stick-slip is assessed and its peak, the cyclic periods from the periodogram of the fit's
// residual and their refinement.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "analysis/core/parallel.h"
#include "analysis/dbb/diagnosis_run.h"

namespace km::dbb::diag {

void DiagnosisRun::AddStickSlipAndCyclicErrors(FitResult& f2) {
  const bool stick = StickSlipAssessed();
  double peak = 0.0, chi2 = 0.0;
  std::array<double, 2> cyclic{0.0, 0.0};  // period of each axis, 0 when not detected
  ParallelFor(
      3,
      [&](std::size_t k) {
        if (k == 2) {
          if (stick) peak = StickSlipPeak(f2, &chi2);
        } else {
          cyclic[k] = CyclicPeriod(f2, static_cast<int>(k));
        }
      },
      threads_);
  if (stick && AddStickSlip(f2, peak, chi2)) {
    ParallelFor(
        2, [&](std::size_t k) { cyclic[k] = CyclicPeriod(f2, static_cast<int>(k)); }, threads_);
  }
  AddCyclicErrors(cyclic);
}

// Stick-slip teeth shorter than three samples alias into longer, reversed ones: with steps
// above stick_slip_max_step_deg the sawtooth is not assessed at all.
bool DiagnosisRun::StickSlipAssessed() {
  const double lo = std::max(opt_.stick_slip_min_period_deg, 3.0 * median_step_);
  const double hi = opt_.stick_slip_max_period_deg;
  if (!(hi > lo && median_step_ <= opt_.stick_slip_max_step_deg)) {
    not_assessed_.push_back(serial_effects::EffectName(EffectId::kStickSlip, first_, second_) +
                            " (samples too far apart to resolve its teeth)");
    return false;
  }
  return zones_.idx.size() > 10;
}

// Stick-slip, a sawtooth in the low-speed zones; period from a periodogram over the angle since
// the reversal (0 when none; `chi2` its peak's strength).
double DiagnosisRun::StickSlipPeak(const FitResult& f2, double* chi2) const {
  const double lo = std::max(opt_.stick_slip_min_period_deg, 3.0 * median_step_);
  const double hi = opt_.stick_slip_max_period_deg;
  const double s2 =
      std::max(std::pow(DiffNoiseUm(p_, f2.residual), 2), f2.residual.squaredNorm() / f2.dof);
  return StickPeriodPeak(zones_, f2.residual, lo, hi, s2, chi2);
}

// The periodogram's peak refined on the exact signature and tried when it stands out; true
// when the sawtooth joins the model (f2 is then refitted).
bool DiagnosisRun::AddStickSlip(FitResult& f2, double peak, double chi2) {
  // The transform's peak must stand out before the fine scan is worth its cost: ~500
  // independent frequencies of exponentially distributed power (mean 1) exceed 15 by chance
  // with probability ~1e-4.
  if (!(peak > 0.0 && chi2 > 15.0)) return false;
  const double s2 =
      std::max(std::pow(DiffNoiseUm(p_, f2.residual), 2), f2.residual.squaredNorm() / f2.dof);
  const Base b2 = MakeBase(f2);
  std::pair<double, double> best{0.0, -1.0};  // period, gain
  const double fringe = peak * peak / 180.0;
  for (double fine : FineStickPeriods(zones_, f2.residual, peak)) {
    const auto r = RefineStickPeriod(p_, zones_, b2, fine, fringe / 16.0, median_step_, buf_);
    if (r.second > best.second) best = r;
  }
  best = PreferCommensurate(p_, zones_, b2, best, 4.0 * fringe, median_step_, buf_);
  if (!(best.second / s2 > opt_.stick_slip_detection_chi2)) return false;
  cands_.push_back(MakeCandidate(p_, EffectId::kStickSlip, {best.first}));
  f2 = FitAll(cands_);
  return true;
}

// Cyclic error of one axis: period search on the residual of the model so far; 0 when none is
// detected. Searched only when the residual is not white: a smooth periodic error raises its
// variance above the successive-difference estimate of the noise variance.
double DiagnosisRun::CyclicPeriod(const FitResult& f2, int axis) const {
  if (!opt_.search_cyclic) return 0.0;
  const Spacing sp = TraceSpacing(traces_);
  const double pmin = std::max(opt_.cyclic_min_period_mm, 4.0 * sp.rmin * sp.max_step);
  const double pmax = opt_.cyclic_max_period_fraction * sp.rmin;
  const double s2 = std::pow(DiffNoiseUm(p_, f2.residual), 2);
  const double var = f2.residual.squaredNorm() / p_.n;
  const bool structured = var > s2 * (1.0 + 4.0 * std::sqrt(2.0 / p_.n));
  if (!(structured && pmax > pmin && s2 > 0.0)) return 0.0;
  const double period = CyclicPeriodPeak(p_, f2.residual, axis, pmin, pmax);
  if (!(period > 0.0)) return 0.0;
  // Projection energy of the residual (on a subsample that keeps ≥ 4 samples a period),
  // scaled to the full sample count, against the noise variance.
  const int stride = std::max(1, static_cast<int>(period / (4.0 * sp.rmin * sp.max_step)));
  const double energy = stride * CyclicEnergy(p_, f2.residual, axis, period, stride);
  return energy / s2 > opt_.cyclic_detection_chi2 ? period : 0.0;
}

void DiagnosisRun::AddCyclicErrors(const std::array<double, 2>& found) {
  std::vector<CandidateSpec> specs;
  for (std::size_t axis = 0; axis < 2; ++axis) {
    if (found[axis] > 0.0) {
      specs.push_back(
          {axis == 0 ? EffectId::kCyclicErrorU : EffectId::kCyclicErrorV, {found[axis]}});
    }
  }
  for (auto& c : MakeCandidates(p_, specs, threads_)) cands_.push_back(std::move(c));
}

// Cyclic periods refined by one backfitting step: maximise the projection energy of the partial
// residual (data minus every other jointly fitted effect) within ±2 periodogram bins.
void DiagnosisRun::RefineCyclicPeriods(FitResult& f3) {
  const Spacing sp = TraceSpacing(traces_);
  std::vector<std::size_t> kept;  // indices into f3.kept of the cyclic errors
  for (std::size_t j = 0; j < f3.kept.size(); ++j) {
    const EffectId id = cands_[static_cast<std::size_t>(f3.kept[j])].id;
    if (id == EffectId::kCyclicErrorU || id == EffectId::kCyclicErrorV) kept.push_back(j);
  }
  if (kept.empty()) return;
  std::vector<CandidateSpec> specs(kept.size());
  ParallelFor(
      kept.size(),
      [&](std::size_t k) {
        const std::size_t j = kept[k];
        const Candidate& c = cands_[static_cast<std::size_t>(f3.kept[j])];
        const int axis = c.id == EffectId::kCyclicErrorU ? 0 : 1;
        const VectorXd partial = f3.residual + f3.Combine(f3.first_col[j], 2, p_.n);
        const double period = c.shape[0];
        const double bin_rel = 2.0 * period * kCyclicBins / (2.0 * kCyclicFft * sp.rmin);
        specs[k] = {c.id,
                    {RefinePeriod(p_, partial, axis, period, std::min(0.2, bin_rel),
                                  sp.rmin * sp.max_step)}};
      },
      threads_);
  std::vector<Candidate> refined = MakeCandidates(p_, specs, threads_);
  for (std::size_t k = 0; k < kept.size(); ++k)
    cands_[static_cast<std::size_t>(f3.kept[kept[k]])] = std::move(refined[k]);
  f3 = FitAll(cands_);
}

// Fitted shapes, jointly: each spike's width and decay shape and the stick-slip period again,
// against the model of every other effect (one backfitting pass). The candidates are refined in
// parallel: each fit leaves one column out of the last full fit, whose inner products are all
// cached, so the cache is only read.

}  // namespace km::dbb::diag
