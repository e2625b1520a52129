#include "analysis/dbb/diagnosis.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <thread>
#include <tuple>
#include <utility>

#include <Eigen/Core>

#include "analysis/core/angles.h"
#include "analysis/core/errors.h"
#include "analysis/core/extremes.h"
#include "analysis/core/parallel.h"
#include "analysis/dbb/diagnosis_entry.h"
#include "analysis/dbb/diagnosis_fit.h"
#include "analysis/dbb/diagnosis_run.h"
#include "analysis/dbb/diagnosis_search.h"
#include "analysis/dbb/iso230.h"
#include "analysis/dbb/signatures.h"

namespace km::dbb {

namespace {

using namespace diag;  // NOLINT(google-build-using-namespace): the diagnosis' own internals
using Eigen::VectorXd;
using serial_effects::EffectId;

// Sample steps a spike must cover above e⁻² of its height to be named (DiagnosisRun::Screen).
constexpr double kSpikeMinSamples = 3.0;
constexpr const char* kUnresolvedSpike =
    " (narrower than the samples resolve: its height is not determined)";

// The best width of each decay shape of a search (exponential first).
std::array<double, 2> SpikeWidths(const SpikeFit& s) {
  return s.best.exponent == 1.0 ? std::array<double, 2>{s.best.width, s.other.width}
                                : std::array<double, 2>{s.other.width, s.best.width};
}

// A step in degrees as the files write it: the rounding of the degree → radian conversion
// undone (6 significant digits); `scale` receives the power of ten used.
double FileStepDeg(double step_rad, double* scale) {
  const double deg = step_rad / kDeg;  // a division by a positive constant keeps the order
  *scale = std::pow(10.0, 6 - std::ceil(std::log10(deg)));
  return std::round(deg * *scale) / *scale;
}

double MedianStepDeg(const std::vector<DiagnosisTrace>& traces) {
  std::vector<double> steps;
  std::size_t total = 0;
  for (const auto& t : traces) total += t.angle_rad.size();
  steps.reserve(total);
  for (const auto& t : traces)
    for (std::size_t i = 1; i < t.angle_rad.size(); ++i)
      steps.push_back(std::abs(t.angle_rad[i] - t.angle_rad[i - 1]));
  if (steps.empty()) return 0.0;
  // Steps that all read the same in the file (the usual even sampling): the median reads so
  // too (the reading is non-decreasing in the step), without selecting it.
  const auto [lo, hi] = Extremes(steps.data(), steps.size());
  double scale_lo = 0.0, scale_hi = 0.0;
  const double read_lo = FileStepDeg(lo, &scale_lo), read_hi = FileStepDeg(hi, &scale_hi);
  if (read_lo == read_hi && scale_lo == scale_hi) return read_lo;
  auto mid = steps.begin() + static_cast<long>(steps.size() / 2);
  std::nth_element(steps.begin(), mid, steps.end());
  double scale = 0.0;
  return FileStepDeg(*mid, &scale);
}

// Effects fitted first, with a fixed shape: every linear form effect of the registry without
// shape parameters, in registry order (the order decides which of two confounded effects is
// kept). Effects with a shape (spikes, stick-slip, cyclic errors) join after their search.
std::vector<EffectId> FixedShapeEffects() {
  std::vector<EffectId> ids;
  for (const auto& info : serial_effects::AllEffects()) {
    if (info.in_form && info.linear_fit && info.num_params == info.num_linear) {
      ids.push_back(info.id);
    }
  }
  return ids;
}

}  // namespace

namespace diag {

DiagnosisRun::DiagnosisRun(const std::vector<DiagnosisTrace>& traces, Plane plane,
                           const DiagnosisOptions& opt)
    : traces_(traces), opt_(opt) {
  const auto axes = AxisLetters(plane);
  first_ = axes.first;
  second_ = axes.second;
  static_cast<StackedTraces&>(p_) = StackTraces(traces, /*leave_out_reversals=*/true);
  p_.ComputeReversalPhases();  // read by every spike signature and the reversal orders
  // Set-up fit (centre, radius per trace) and the residual about it.
  e0_ = p_.y;
  p_.RemoveSetup(e0_, &setup_);
  median_step_ = MedianStepDeg(traces);
  threads_ = opt.threads > 0 ? opt.threads : std::max(1u, std::thread::hardware_concurrency());
  ctx_ = {&p_, &e0_, opt.confound_ratio, first_, second_, &cache_, false, threads_};
  spike_lo_ = std::max(opt.spike_min_width_deg, 0.5 * median_step_);
  spike_hi_ = opt.spike_max_width_deg;
  if (spike_hi_ > spike_lo_) order_.resize(2);
  ParallelFor(
      3,
      [&](std::size_t k) {
        if (k == 2) {
          zones_ = MakeStickZones(p_);
        } else if (!order_.empty()) {
          order_[k] =
              MakeReversalOrder(p_, k == 0 ? EffectId::kReversalSpikeU : EffectId::kReversalSpikeV,
                                SpikeMaxReach(spike_hi_));
        }
      },
      threads_);
}

DiagnosisResult DiagnosisRun::Run() {
  std::vector<CandidateSpec> fixed;
  for (EffectId id : FixedShapeEffects()) fixed.push_back({id, {}});
  cands_ = MakeCandidates(p_, fixed, threads_);
  const FitResult f1 = FitAll(cands_);
  AddSpikes(f1);
  FitResult f2 = FitAll(cands_);
  AddStickSlipAndCyclicErrors(f2);
  FitResult f3 = FitAll(cands_);
  RefineCyclicPeriods(f3);
  RefineShapes(f3);

  DiagnosisResult res;
  res.not_identifiable = f3.dropped;
  res.not_identifiable.insert(res.not_identifiable.end(), not_assessed_.begin(),
                              not_assessed_.end());
  std::vector<Candidate> chosen = Screen(f3, res);
  RefineNamedSpikes(chosen);
  // Refit with the named form effects only; uncertainties with the fitted shapes.
  FitResult f4 = FitAll(chosen);
  AugmentShapes(p_, chosen, f4, threads_);
  const VectorXd final_res = NameEffects(chosen, f4, res);
  AddSetupEntries(f4, res);
  RankNamed(final_res, res);
  return res;
}

// Reversal spikes: width and decay shape fitted against the fixed-shape model.
void DiagnosisRun::AddSpikes(const FitResult& f1) {
  if (order_.empty()) {
    for (EffectId id : {EffectId::kReversalSpikeU, EffectId::kReversalSpikeV}) {
      not_assessed_.push_back(serial_effects::EffectName(id, first_, second_) +
                              " (samples too far apart to resolve a spike)");
    }
    return;
  }
  const Base b1 = MakeBase(f1);
  std::array<SpikeFit, 2> shape;
  ParallelFor(
      2,
      [&](std::size_t axis) {
        shape[axis] = SearchSpike(p_, order_[axis], b1, spike_lo_, spike_hi_, 10);
      },
      threads_);
  std::vector<CandidateSpec> found;
  std::vector<std::array<double, 2>> widths;
  for (std::size_t axis = 0; axis < 2; ++axis) {
    const SpikeFit& s = shape[axis];
    const EffectId id = axis == 0 ? EffectId::kReversalSpikeU : EffectId::kReversalSpikeV;
    if (!(s.best.gain > 0.0)) continue;
    found.push_back({id, {s.best.width, s.best.exponent}});
    widths.push_back(SpikeWidths(s));
  }
  for (auto& c : MakeCandidates(p_, found, threads_)) cands_.push_back(std::move(c));
  for (std::size_t k = 0; k < widths.size(); ++k)
    cands_[cands_.size() - widths.size() + k].spike_widths = widths[k];
}

// Stick-slip, then cyclic errors, each searched on the residual of the model so far. The two
// period searches read the same residual and run at once; the cyclic one is repeated when a
// stick-slip sawtooth joins the model (its residual changes).
void DiagnosisRun::RefineShapes(FitResult& f3) {
  std::vector<double> z(cands_.size(), 0.0);  // |value| / σ of the kept candidates in f3
  for (std::size_t j = 0; j < f3.kept.size(); ++j) {
    const int c = f3.first_col[j];
    if (f3.cov(c, c) > 0.0) {
      z[static_cast<std::size_t>(f3.kept[j])] = std::abs(f3.x[c]) / std::sqrt(f3.cov(c, c));
    }
  }
  // Not worth refining what is clearly not there (z < 2): it will not be named.
  std::vector<std::size_t> todo;
  for (std::size_t q = 0; q < cands_.size(); ++q)
    if (HasFittedShape(cands_[q].id) && z[q] >= 2.0) todo.push_back(q);
  if (todo.empty()) return;
  std::vector<Refined> shape(todo.size());
  FitContext ctx = ctx_;
  ctx.read_only_cache = true;
  ctx.threads = 1;
  ParallelFor(
      todo.size(), [&](std::size_t k) { shape[k] = RefinedShape(ctx, cands_, todo[k]); }, threads_);
  std::vector<std::size_t> changed;
  std::vector<CandidateSpec> specs;
  for (std::size_t k = 0; k < todo.size(); ++k) {
    if (!shape[k].shape) continue;
    changed.push_back(todo[k]);
    specs.push_back({cands_[todo[k]].id, std::move(*shape[k].shape)});
  }
  std::vector<Candidate> refined = MakeCandidates(p_, specs, threads_);
  for (std::size_t k = 0; k < changed.size(); ++k) cands_[changed[k]] = std::move(refined[k]);
  for (std::size_t k = 0; k < todo.size(); ++k) {
    cands_[todo[k]].shape_doubt_var = shape[k].shape_doubt_var;
    if (shape[k].spike_widths[0] > 0.0) cands_[todo[k]].spike_widths = shape[k].spike_widths;
  }
  if (!changed.empty()) f3 = FitAll(cands_);
}

// The shape of candidate q refitted against every other candidate (none when the search finds
// nothing or the shape is exact), and for a spike the doubt about its decay shape: the noise
// variance is that of the base with the spike, one height and one width more. A spike's width is
// searched over the whole range, or with `near_known` near the widths found before
// (RefineSpike: the named effects' refit, where a width moves little).
DiagnosisRun::Refined DiagnosisRun::RefinedShape(const FitContext& ctx,
                                                 const std::vector<Candidate>& cands, std::size_t q,
                                                 bool near_known) const {
  const EffectId id = cands[q].id;
  const Base b = MakeBase(Fit(ctx, Pointers(cands, q)));
  if (IsSpike(id)) {
    const auto axis = static_cast<std::size_t>(id == EffectId::kReversalSpikeU ? 0 : 1);
    const auto& known = cands[q].spike_widths;
    const SpikeFit s = near_known && known[0] > 0.0 && known[1] > 0.0
                           ? RefineSpike(p_, order_[axis], b, known, spike_lo_, spike_hi_)
                           : SearchSpike(p_, order_[axis], b, spike_lo_, spike_hi_, 8);
    if (!(s.best.gain > 0.0)) return {};
    const int dof = p_.n - 3 * p_.traces - b.m - 2;
    const double s2 = dof > 0 ? std::max(0.0, b.r.squaredNorm() - s.best.gain) / dof : 0.0;
    return {std::vector<double>{s.best.width, s.best.exponent}, ShapeDoubtVariance(s, s2),
            SpikeWidths(s)};
  }
  const double period = cands[q].shape[0];
  const double tol = period * 1e-6;
  // The teeth fall on the samples: the period is exact.
  if (!CommensuratePeriods(period - tol, period + tol, median_step_).empty()) return {};
  Sparse buf;
  const auto r =
      RefineStickPeriod(p_, zones_, b, period, period * period / 180.0 / 32.0, median_step_, buf);
  if (r.second > 0.0) return {std::vector<double>{r.first}};
  return {};
}

// The widths and decay shapes of the chosen spikes once more, against the chosen effects only:
// the final fit's covariance is that of the final model, and the shapes are then its own.
void DiagnosisRun::RefineNamedSpikes(std::vector<Candidate>& chosen) {
  std::vector<std::size_t> todo;
  for (std::size_t q = 0; q < chosen.size(); ++q)
    if (IsSpike(chosen[q].id)) todo.push_back(q);
  if (todo.empty()) return;
  FitContext ctx = ctx_;
  ctx.read_only_cache = true;
  ctx.threads = 1;
  std::vector<Refined> shape(todo.size());
  ParallelFor(
      todo.size(), [&](std::size_t k) { shape[k] = RefinedShape(ctx, chosen, todo[k], true); },
      threads_);
  for (std::size_t k = 0; k < todo.size(); ++k) {
    Candidate& c = chosen[todo[k]];
    if (shape[k].shape && *shape[k].shape != c.shape) c = MakeCandidate(p_, c.id, *shape[k].shape);
    c.shape_doubt_var = shape[k].shape_doubt_var;
    c.spike_widths = shape[k].spike_widths;
  }
}

// Every estimated effect becomes a candidate entry; the significant ones with enough
// contribution are chosen for the final fit (moved out of the candidates: the last stage).
std::vector<Candidate> DiagnosisRun::Screen(const FitResult& f3, DiagnosisResult& res) {
  std::vector<DiagnosisEntry> stage3(f3.kept.size());
  ParallelFor(
      f3.kept.size(),
      [&](std::size_t j) {
        stage3[j] =
            MakeEntry(p_, cands_[static_cast<std::size_t>(f3.kept[j])], f3, j, first_, second_);
      },
      threads_);
  std::vector<DiagnosisEntry*> ptrs;
  for (auto& e : stage3) ptrs.push_back(&e);
  Normalise(p_, ptrs, f3.residual);
  std::vector<Candidate> chosen;
  for (std::size_t j = 0; j < stage3.size(); ++j) {
    Candidate& c = cands_[static_cast<std::size_t>(f3.kept[j])];
    if (Significant(stage3[j], opt_) && stage3[j].MaxContribution() >= opt_.min_contribution_pct) {
      if (IsSpike(c.id) && !SpikeResolved(c)) {
        res.not_identifiable.push_back(stage3[j].effect + kUnresolvedSpike);
      } else {
        chosen.push_back(std::move(c));
      }
    }
    res.candidates.push_back(std::move(stage3[j]));
  }
  return chosen;
}

// A spike of width w is above e⁻² of its height for φ ≤ 2w, whichever its decay shape: its
// height and width are told apart by at least kSpikeMinSamples sample steps there. A narrower
// one shows on a sample or two after each reversal, whose values any height fits with a width to
// match: its height is not determined by the samples.
bool DiagnosisRun::SpikeResolved(const Candidate& c) const {
  return 2.0 * c.shape[0] >= kSpikeMinSamples * median_step_;
}

// Named effects of the final fit, their summed model per trace, and the set-up terms net of
// their own mean and first harmonic. Returns what the named effects leave unexplained.
VectorXd DiagnosisRun::NameEffects(const std::vector<Candidate>& chosen, const FitResult& f4,
                                   DiagnosisResult& res) {
  std::vector<DiagnosisEntry> entries(f4.kept.size());
  ParallelFor(
      f4.kept.size(),
      [&](std::size_t j) {
        entries[j] =
            MakeEntry(p_, chosen[static_cast<std::size_t>(f4.kept[j])], f4, j, first_, second_);
      },
      threads_);
  VectorXd model = VectorXd::Zero(p_.n);
  for (std::size_t j = 0; j < f4.kept.size(); ++j) {
    const auto& c = chosen[static_cast<std::size_t>(f4.kept[j])];
    DiagnosisEntry& en = entries[j];
    if (!Significant(en, opt_)) continue;
    const int nl = static_cast<int>(c.cols.size());
    model += f4.Combine(f4.first_col[j], nl, p_.n);
    // The set-up fit absorbed this effect's own mean and first harmonic: give them back.
    for (int m = 0; m < nl; ++m)
      NetSetup(setup_, f4.x[f4.first_col[j] + m], c.setup_part[static_cast<std::size_t>(m)]);
    en.named = true;
    res.named.push_back(std::move(en));
  }
  const VectorXd final_res = e0_ - model;
  res.residual_rms_um = std::sqrt(final_res.squaredNorm() / p_.n);
  res.noise_um = DiffNoiseUm(p_, final_res);
  res.form_model_um.assign(traces_.size(), {});
  for (int t = 0; t < p_.traces; ++t) {
    res.form_model_um[static_cast<std::size_t>(t)].assign(model.data() + p_.begin[t],
                                                          model.data() + p_.begin[t + 1]);
  }
  return final_res;
}

DiagnosisEntry DiagnosisRun::SetupEntry(EffectId id, std::vector<double> value,
                                        std::vector<double> sigma) const {
  DiagnosisEntry e;
  e.id = id;
  e.effect = serial_effects::EffectName(id, first_, second_);
  e.unit = serial_effects::Info(id).unit;
  e.value = std::move(value);
  e.params = e.value;
  e.uncertainty = std::move(sigma);
  e.contribution_pct.assign(traces_.size(), 0.0);
  e.peak_to_valley_um.assign(traces_.size(), 0.0);
  return e;
}

// Set-up terms: centre offset and radius change (mean over the traces).
void DiagnosisRun::AddSetupEntries(const FitResult& f4, DiagnosisResult& res) const {
  const SetupMean sm = MeanSetup(p_, setup_, f4.sigma2);
  const Eigen::Vector3d& mean = sm.mean;
  const Eigen::Vector3d& var = sm.var;
  DiagnosisEntry c = SetupEntry(EffectId::kCentreOffset, {mean[0], mean[1]},
                                {std::sqrt(var[0]), std::sqrt(var[1])});
  c.significance = ZScore(std::hypot(mean[0], mean[1]), std::sqrt(0.5 * (var[0] + var[1])));
  DiagnosisEntry r = SetupEntry(EffectId::kRadiusError, {mean[2]}, {std::sqrt(var[2])});
  r.significance = ZScore(mean[2], std::sqrt(var[2]));
  for (DiagnosisEntry* e : {&c, &r}) {
    e->named = Significant(*e, opt_);
    res.candidates.push_back(*e);
    if (e->named) res.named.push_back(*e);
  }
}

// Final contributions: named form effects against what is left unexplained; ranked.
void DiagnosisRun::RankNamed(const VectorXd& final_res, DiagnosisResult& res) const {
  std::vector<DiagnosisEntry*> ptrs;
  for (auto& e : res.named)
    if (serial_effects::Info(e.id).in_form) ptrs.push_back(&e);
  Normalise(p_, ptrs, final_res);
  res.named.erase(std::remove_if(res.named.begin(), res.named.end(),
                                 [&](const DiagnosisEntry& e) {
                                   return serial_effects::Info(e.id).in_form &&
                                          e.MaxContribution() < opt_.min_contribution_pct;
                                 }),
                  res.named.end());
  std::stable_sort(res.named.begin(), res.named.end(),
                   [](const DiagnosisEntry& a, const DiagnosisEntry& b) {
                     const double ca = a.MaxContribution(), cb = b.MaxContribution();
                     if (ca != cb) return ca > cb;
                     return a.significance > b.significance;
                   });
}

}  // namespace diag

DiagnosisResult DiagnoseSerialDbb(const std::vector<DiagnosisTrace>& traces, Plane plane,
                                  const DiagnosisOptions& opt) {
  opt.Check();
  if (traces.empty()) throw InvalidInput("", 0, "tests", "no trace to diagnose");
  DiagnosisRun run(traces, plane, opt);
  return run.Run();
}

}  // namespace km::dbb
