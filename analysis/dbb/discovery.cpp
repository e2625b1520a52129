#include "analysis/dbb/discovery.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/core/errors.h"
#include "analysis/dbb/signatures.h"

namespace km::dbb {

namespace {

using effects::EffectId;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// Continued fraction of I_x(a, b) (modified Lentz), valid and fast for x < (a + 1)/(a + b + 2).
double BetaContinuedFraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  constexpr double kEps = 1e-15;
  constexpr int kMaxIter = 100000;
  const double qab = a + b, qap = a + 1.0, qam = a - 1.0;
  double c = 1.0;
  double d = 1.0 - qab * x / qap;
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= kMaxIter; ++m) {
    const double m2 = 2.0 * m;
    // Even term d_2m = m (b − m) x / ((a + 2m − 1)(a + 2m)).
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    h *= d * c;
    // Odd term d_2m+1 = −(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)).
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < kEps) return h;
  }
  throw DidNotConverge("incomplete beta continued fraction did not converge");
}

// log of x^a (1 − x)^b / B(a, b), with 1 − x given separately (no cancellation).
double LogBetaFront(double a, double b, double x, double one_minus_x) {
  return std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) +
         b * std::log(one_minus_x);
}

// Robust σ of pooled successive differences: 1.4826 · MAD / √2.
double MadSigma(std::vector<double> d) {
  if (d.empty()) return 0.0;
  auto median = [](std::vector<double>& v) {
    const std::size_t h = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(h), v.end());
    double m = v[h];
    if (v.size() % 2 == 0) {
      m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(h)));
    }
    return m;
  };
  const double med = median(d);
  for (double& x : d) x = std::abs(x - med);
  return 1.4826 * median(d) / std::numbers::sqrt2;
}

double NoiseFloor(const StackedTraces& p, const VectorXd& r) {
  std::vector<std::vector<double>> per_trace(static_cast<std::size_t>(p.traces));
  for (int t = 0; t < p.traces; ++t) {
    per_trace[static_cast<std::size_t>(t)].assign(r.data() + p.begin[t], r.data() + p.begin[t + 1]);
  }
  return RobustDiffNoiseUm(per_trace);
}

double Rms(const VectorXd& v) {
  return v.size() > 0 ? std::sqrt(v.squaredNorm() / static_cast<double>(v.size())) : 0.0;
}

// Projects v on the orthogonal complement of the orthonormal vectors q (Gram–Schmidt, twice
// for numerical orthogonality).
void Reduce(const std::vector<VectorXd>& q, VectorXd& v) {
  for (int pass = 0; pass < 2; ++pass)
    for (const auto& qi : q) v -= qi.dot(v) * qi;
}

// A candidate effect with its shape fixed (one spike width, one period, …).
struct Variant {
  EffectColumns sig;
  int order = 0;  // position in the registry list (priority when confounded)
};

// A candidate tried against the current model.
struct Trial {
  std::size_t variant = 0;
  bool identifiable = true;
  std::string confounded_with;
  std::vector<VectorXd> q;  // orthonormal basis of the projected columns
  double drop = 0.0;        // RSS reduction
};

// Joint least-squares refit of set-up-free columns to the set-up-free data e0.
struct Refit {
  VectorXd x;
  MatrixXd cov;
  VectorXd residual;
  double rss = 0.0;
  double sigma2 = 0.0;
  int dof = 0;
};

Refit JointRefit(const StackedTraces& p, const std::vector<const EffectColumns*>& model,
                 const VectorXd& e0) {
  int k = 0;
  for (const auto* m : model) k += static_cast<int>(m->cols.size());
  Refit r;
  r.dof = p.n - 3 * p.traces - k;
  if (r.dof <= 0) throw NotObservable("discovery: more parameters than samples");
  MatrixXd a(p.n, k);
  int c = 0;
  for (const auto* m : model)
    for (const auto& col : m->cols) a.col(c++) = col;
  if (k > 0) {
    const MatrixXd g = a.transpose() * a;
    const Eigen::LDLT<MatrixXd> ldlt(g);
    r.x = ldlt.solve(a.transpose() * e0);
    r.residual = e0 - a * r.x;
    r.rss = r.residual.squaredNorm();
    r.sigma2 = r.rss / r.dof;
    r.cov = r.sigma2 * ldlt.solve(MatrixXd::Identity(k, k));
  } else {
    r.residual = e0;
    r.rss = e0.squaredNorm();
    r.sigma2 = r.rss / r.dof;
  }
  return r;
}

// Value, σ and z-score of the effect whose linear parameters start at column `off`.
struct EffectValue : EffectEstimate {
  bool two_value = false;
};

EffectValue ValueOf(const StackedTraces& p, const EffectColumns& e, const Refit& r, int off) {
  EffectValue v;
  static_cast<EffectEstimate&>(v) = EstimateEffect(p, e.id, e.shape, r.x, r.cov, off);
  v.two_value = v.value.size() > 1 || effects::Info(e.id).num_linear > 1;
  return v;
}

std::map<std::string, double> ParameterMap(const EffectColumns& e, const EffectValue& v) {
  const auto& info = effects::Info(e.id);
  std::map<std::string, double> m;
  for (int j = 0; j < info.num_params; ++j) {
    m[info.param_names[static_cast<std::size_t>(j)]] = v.params[static_cast<std::size_t>(j)];
  }
  return m;
}

std::map<std::string, double> ShapeMap(const EffectColumns& e) {
  const auto& info = effects::Info(e.id);
  std::map<std::string, double> m;
  for (std::size_t k = 0; k < e.shape.size(); ++k) {
    m[info.param_names[static_cast<std::size_t>(info.num_linear) + k]] = e.shape[k];
  }
  return m;
}

bool IsSpike(EffectId id) {
  return id == EffectId::kReversalSpikeU || id == EffectId::kReversalSpikeV;
}
bool IsCyclic(EffectId id) {
  return id == EffectId::kCyclicErrorU || id == EffectId::kCyclicErrorV;
}

}  // namespace

void DiscoveryOptions::Check() const {
  if (!(max_p_value > 0.0 && max_p_value < 1.0))
    throw InvalidInput("", 0, "max_p_value", "must be within (0, 1)");
  if (!(significance > 0.0)) throw InvalidInput("", 0, "significance", "must be positive");
  if (!(confound_ratio > 0.0 && confound_ratio < 1.0))
    throw InvalidInput("", 0, "confound_ratio", "must be within (0, 1)");
  if (!(noise_stop_fraction >= 0.0)) throw InvalidInput("", 0, "noise_stop_fraction", ">= 0");
  if (spike_widths_deg.empty()) throw InvalidInput("", 0, "spike_widths_deg", "empty");
  for (double w : spike_widths_deg)
    if (!(w > 0.0)) throw InvalidInput("", 0, "spike_widths_deg", "must be positive");
  if (!(cyclic_min_period_mm > 0.0)) throw InvalidInput("", 0, "cyclic_min_period_mm", "> 0");
  if (!(cyclic_max_period_fraction > 0.0))
    throw InvalidInput("", 0, "cyclic_max_period_fraction", "> 0");
  if (max_steps < 0) throw InvalidInput("", 0, "max_steps", ">= 0");
  if (!(resolution_um >= 0.0)) throw InvalidInput("", 0, "resolution_um", ">= 0");
}

double RegularisedIncompleteBeta(double a, double b, double x) {
  if (!(a > 0.0 && b > 0.0)) throw InvalidInput("", 0, "a, b", "must be positive");
  if (!(x >= 0.0 && x <= 1.0)) throw InvalidInput("", 0, "x", "must be within [0, 1]");
  if (x == 0.0) return 0.0;
  if (x == 1.0) return 1.0;
  const double front = std::exp(LogBetaFront(a, b, x, 1.0 - x));
  if (x < (a + 1.0) / (a + b + 2.0)) return front * BetaContinuedFraction(a, b, x) / a;
  return 1.0 - front * BetaContinuedFraction(b, a, 1.0 - x) / b;
}

double LogFUpperTail(double f, double d1, double d2) {
  if (!(d1 > 0.0 && d2 > 0.0)) throw InvalidInput("", 0, "degrees of freedom", "must be > 0");
  if (!(f > 0.0)) return 0.0;  // P = 1
  if (std::isinf(f)) return -std::numeric_limits<double>::infinity();
  // P(F > f) = I_x(d2/2, d1/2), x = d2 / (d2 + d1 f); 1 − x computed without cancellation.
  const double a = 0.5 * d2, b = 0.5 * d1;
  const double x = d2 / (d2 + d1 * f);
  const double one_minus_x = d1 * f / (d2 + d1 * f);
  const double log_front = LogBetaFront(a, b, x, one_minus_x);
  if (x < (a + 1.0) / (a + b + 2.0)) {
    // Direct branch, in logs so that tiny p-values do not underflow.
    return log_front + std::log(BetaContinuedFraction(a, b, x)) - std::log(a);
  }
  const double q = std::exp(log_front) * BetaContinuedFraction(b, a, one_minus_x) / b;
  return std::log1p(-std::min(q, 1.0));
}

double RobustDiffNoiseUm(const std::vector<std::vector<double>>& residual_per_trace) {
  std::vector<double> d;
  for (const auto& r : residual_per_trace)
    for (std::size_t i = 1; i < r.size(); ++i) d.push_back(r[i] - r[i - 1]);
  return MadSigma(std::move(d));
}

namespace {

// The effect chosen at a step among those the data cannot tell apart, with its evidence.
struct Choice {
  const Trial* chosen = nullptr;
  const Trial* runner = nullptr;  // best other effect (any shape) at this step
  std::vector<std::string> indistinguishable;
};

// Each projected signature (orthonormal q) lies within the other's span up to the ratio.
bool Within(const std::vector<VectorXd>& a, const std::vector<VectorXd>& b, double ratio) {
  for (const auto& q : a) {
    VectorXd v = q;
    Reduce(b, v);
    if (v.squaredNorm() >= ratio * ratio) return false;
  }
  return true;
}

// One discovery: model 0 (the set-up terms), then steps that each add the effect that most
// reduces the gap, while it passes the F-test and its value is significant.
class DiscoveryRun {
 public:
  DiscoveryRun(const std::vector<DiagnosisTrace>& traces, Plane plane, const DiscoveryOptions& opt);
  DiscoveryRun(const DiscoveryRun&) = delete;
  DiscoveryRun& operator=(const DiscoveryRun&) = delete;
  DiscoveryResult Run();

 private:
  std::string Name(EffectId id) const { return effects::EffectName(id, first_, second_); }
  bool InModel(EffectId id) const {
    return std::any_of(model_.begin(), model_.end(), [&](const auto& m) { return m.id == id; });
  }
  void BuildFixedVariants();
  std::vector<Variant> CyclicVariants() const;
  Trial TryVariant(const Variant& v, std::size_t k) const;
  Choice Choose(const std::vector<const Variant*>& variants, const std::vector<Trial>& trials,
                const Trial& best) const;
  bool Step(DiscoveryResult& res);
  void FinalModel(DiscoveryResult& res);

  const DiscoveryOptions& opt_;
  char first_ = 'x';
  char second_ = 'y';
  StackedTraces p_;
  VectorXd e0_;                         // the gap about the set-up terms (model 0)
  std::vector<Eigen::Vector3d> setup_;  // set-up terms per trace
  std::vector<Variant> fixed_;          // fixed-shape candidates, built once
  std::vector<EffectId> cyclic_ids_;    // candidates whose period is searched at each step
  double rmin_ = std::numeric_limits<double>::infinity();
  double max_step_ = 0.0;
  double pmin_ = 0.0;
  double pmax_ = 0.0;
  double linearisation_um_ = 0.0;
  std::vector<EffectColumns> model_;  // accepted effects, in step order
  std::vector<VectorXd> basis_;       // orthonormal basis of their columns
  VectorXd gap_;
  Refit current_;
};

DiscoveryRun::DiscoveryRun(const std::vector<DiagnosisTrace>& traces, Plane plane,
                           const DiscoveryOptions& opt)
    : opt_(opt) {
  const auto axes = AxisLetters(plane);
  first_ = axes.first;
  second_ = axes.second;
  p_ = StackTraces(traces, /*leave_out_reversals=*/true);
  e0_ = p_.y;
  p_.RemoveSetup(e0_, &setup_);
  BuildFixedVariants();
  for (const auto& tr : traces) {
    rmin_ = std::min(rmin_, tr.radius_mm);
    for (std::size_t i = 1; i < tr.angle_rad.size(); ++i)
      max_step_ = std::max(max_step_, std::abs(tr.angle_rad[i] - tr.angle_rad[i - 1]));
  }
  pmin_ = std::max(opt.cyclic_min_period_mm, 4.0 * rmin_ * max_step_);
  pmax_ = opt.cyclic_max_period_fraction * rmin_;
  // The signatures are first order in e/R: the bar length |P + e − F| − |P − F| = e·n +
  // |e_t|²/(2R) + …; below that second-order term a "gap" is geometry, not an effect.
  const double emax = e0_.cwiseAbs().maxCoeff();
  linearisation_um_ = emax * emax / (2.0 * rmin_ * 1000.0);
  gap_ = e0_;
  current_ = JointRefit(p_, {}, e0_);
}

// Candidates: the registry's linear form effects (list order = priority), fixed shapes built
// once; spikes in every width of the set; cyclic errors per step from the current gap.
void DiscoveryRun::BuildFixedVariants() {
  int order = 0;
  for (const auto& info : effects::AllEffects()) {
    ++order;
    if (!info.in_form || !info.linear_fit) continue;
    if (IsCyclic(info.id)) {
      if (opt_.search_cyclic) cyclic_ids_.push_back(info.id);
      continue;
    }
    if (IsSpike(info.id)) {
      for (double w : opt_.spike_widths_deg)
        fixed_.push_back(Variant{SetupFreeSignature(p_, info.id, {w}), order});
    } else {
      fixed_.push_back(Variant{SetupFreeSignature(p_, info.id, {}), order});
    }
  }
}

// Cyclic errors at the period of the strongest peak of the current gap (refined by golden
// section).
std::vector<Variant> DiscoveryRun::CyclicVariants() const {
  std::vector<Variant> cyclic;
  if (!(pmax_ > pmin_)) return cyclic;
  for (EffectId id : cyclic_ids_) {
    if (InModel(id)) continue;
    const int axis = id == EffectId::kCyclicErrorU ? 0 : 1;
    double period = CyclicPeriodPeak(p_, gap_, axis, pmin_, pmax_);
    if (!(period > 0.0)) continue;
    const double bin_rel = 2.0 * period * kCyclicBins / (2.0 * kCyclicFft * rmin_);
    period = RefinePeriod(p_, gap_, axis, period, std::min(0.2, bin_rel), rmin_ * max_step_);
    const int order = static_cast<int>(id) + 1;
    cyclic.push_back(Variant{SetupFreeSignature(p_, id, {period}), order});
  }
  return cyclic;
}

// Identifiability of one variant against the model, and its RSS drop.
Trial DiscoveryRun::TryVariant(const Variant& var, std::size_t k) const {
  const EffectColumns& sig = var.sig;
  Trial t;
  t.variant = k;
  for (const auto& col : sig.cols) {
    VectorXd v = col;
    Reduce(basis_, v);
    Reduce(t.q, v);
    const double left = v.squaredNorm(), full = col.squaredNorm();
    if (!(full > 0.0) || left < opt_.confound_ratio * opt_.confound_ratio * full) {
      t.identifiable = false;
      // The model effect most correlated with this signature.
      double best = -1.0;
      for (const auto& m : model_) {
        for (const auto& mc : m.cols) {
          const double corr = std::abs(mc.dot(col)) / std::sqrt(mc.squaredNorm() * full + 1e-300);
          if (corr > best) {
            best = corr;
            t.confounded_with = Name(m.id);
          }
        }
      }
      return t;
    }
    t.q.push_back(v / std::sqrt(left));
  }
  for (const auto& q : t.q) t.drop += std::pow(q.dot(gap_), 2);
  return t;
}

// Candidates the data cannot tell from the best one given the model (their projected signature
// lies within the confound ratio of the best one's): the earliest in the registry list is taken
// (the diagnosis priority rule), the others are named in the evidence.
Choice DiscoveryRun::Choose(const std::vector<const Variant*>& variants,
                            const std::vector<Trial>& trials, const Trial& best) const {
  std::vector<const Trial*> confused;
  const EffectId best_id = variants[best.variant]->sig.id;
  for (const auto& t : trials) {
    if (!t.identifiable || &t == &best || variants[t.variant]->sig.id == best_id) continue;
    if (Within(t.q, best.q, opt_.confound_ratio) && Within(best.q, t.q, opt_.confound_ratio)) {
      confused.push_back(&t);
    }
  }
  Choice c;
  c.chosen = &best;
  for (const Trial* t : confused)
    if (variants[t->variant]->order < variants[c.chosen->variant]->order) c.chosen = t;
  for (const Trial* t : confused)
    if (t != c.chosen) c.indistinguishable.push_back(Name(variants[t->variant]->sig.id));
  if (c.chosen != &best) c.indistinguishable.push_back(Name(best_id));
  std::sort(c.indistinguishable.begin(), c.indistinguishable.end());
  c.indistinguishable.erase(std::unique(c.indistinguishable.begin(), c.indistinguishable.end()),
                            c.indistinguishable.end());
  const EffectId chosen_id = variants[c.chosen->variant]->sig.id;
  for (const auto& t : trials) {
    if (!t.identifiable || variants[t.variant]->sig.id == chosen_id) continue;
    if (!c.runner || t.drop > c.runner->drop) c.runner = &t;
  }
  return c;
}

// F-test evidence of adding q columns: RSS before/after, F, p.
void FillFTest(const Refit& before, const Refit& after, int q, DiscoveryEvidence& ev,
               double* log_p) {
  ev.rss_before_um2 = before.rss;
  ev.rss_after_um2 = after.rss;
  ev.df_numerator = q;
  ev.df_denominator = after.dof;
  const double drop = std::max(0.0, before.rss - after.rss);
  ev.f_statistic = after.rss > 0.0 ? (drop / q) / (after.rss / after.dof)
                                   : (drop > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
  *log_p = LogFUpperTail(ev.f_statistic, q, after.dof);
  ev.p_value = std::exp(*log_p);
  ev.log10_p_value = std::isinf(*log_p) ? -1e9 : *log_p / std::log(10.0);
  ev.f_statistic = std::min(ev.f_statistic, 1e300);
}

// One step of the ladder; false when the discovery stops (res.stop_reason says why).
bool DiscoveryRun::Step(DiscoveryResult& res) {
  const std::vector<Variant> cyclic = CyclicVariants();
  std::vector<const Variant*> variants;
  for (const auto& v : fixed_)
    if (!InModel(v.sig.id)) variants.push_back(&v);
  for (const auto& v : cyclic) variants.push_back(&v);
  std::vector<Trial> trials;
  res.not_identifiable.clear();
  for (std::size_t k = 0; k < variants.size(); ++k) {
    trials.push_back(TryVariant(*variants[k], k));
    const Trial& t = trials.back();
    if (t.identifiable) continue;
    const std::string s =
        Name(variants[k]->sig.id) + (t.confounded_with.empty()
                                         ? std::string()
                                         : " (confounded with " + t.confounded_with + ")");
    if (std::find(res.not_identifiable.begin(), res.not_identifiable.end(), s) ==
        res.not_identifiable.end())
      res.not_identifiable.push_back(s);
  }
  const double gap_rms = Rms(gap_);
  const double floor = std::max({NoiseFloor(p_, gap_), opt_.resolution_um, linearisation_um_});
  if (gap_rms <= (1.0 + opt_.noise_stop_fraction) * floor) {
    res.stop_reason = "the gap is at the noise floor";
    return false;
  }
  if (static_cast<int>(res.steps.size()) >= opt_.max_steps) {
    res.stop_reason = "maximum number of steps";
    return false;
  }
  const Trial* best = nullptr;
  for (const auto& t : trials)
    if (t.identifiable && (!best || t.drop > best->drop)) best = &t;
  if (!best) {
    res.stop_reason = "no identifiable candidate left";
    return false;
  }
  const Choice choice = Choose(variants, trials, *best);
  const EffectColumns& csig = variants[choice.chosen->variant]->sig;

  // Joint refit with the candidate, F-test and value.
  std::vector<const EffectColumns*> cols;
  for (const auto& m : model_) cols.push_back(&m);
  cols.push_back(&csig);
  const Refit after = JointRefit(p_, cols, e0_);
  const int q = static_cast<int>(csig.cols.size());
  DiscoveryStep step;
  step.id = csig.id;
  step.added_effect = Name(csig.id);
  auto& ev = step.evidence;
  double log_p = 0.0;
  FillFTest(current_, after, q, ev, &log_p);
  const EffectValue val = ValueOf(p_, csig, after, static_cast<int>(after.x.size()) - q);
  ev.value = val.value;
  ev.sigma = val.sigma;
  ev.unit = effects::Info(csig.id).unit;
  ev.z_score = val.z;
  ev.parameters = ParameterMap(csig, val);
  if (choice.runner) {
    ev.runner_up = Name(variants[choice.runner->variant]->sig.id);
    ev.runner_up_rss_drop_um2 = choice.runner->drop;
  }
  ev.indistinguishable_from = choice.indistinguishable;
  step.gap_rms_before_um = gap_rms;
  step.gap_rms_after_um = Rms(after.residual);

  const double z_needed = val.two_value ? opt_.significance + 1.0 : opt_.significance;
  const bool significant_f = log_p < std::log(opt_.max_p_value);
  const bool significant_z = val.z > z_needed;
  if (!significant_f || !significant_z) {
    char buf[256];
    std::snprintf(buf, sizeof buf, "%s (p = %.3g, |value|/sigma = %.3g: %s)",
                  step.added_effect.c_str(), ev.p_value, val.z,
                  !significant_f ? "F-test not significant" : "value not significant");
    res.rejected.push_back(buf);
    res.stop_reason = "the best candidate is not significant";
    return false;
  }
  // Accept: the candidate joins the model.
  for (const auto& qv : choice.chosen->q) basis_.push_back(qv);
  model_.push_back(csig);
  current_ = after;
  gap_ = after.residual;
  res.steps.push_back(std::move(step));
  return true;
}

// Final model: set-up terms net of the accepted effects' own set-up parts, then the effects.
void DiscoveryRun::FinalModel(DiscoveryResult& res) {
  std::vector<const EffectColumns*> cols;
  for (const auto& m : model_) cols.push_back(&m);
  const Refit fin = JointRefit(p_, cols, e0_);
  int off = 0;
  for (const auto& m : model_) {
    for (std::size_t c = 0; c < m.cols.size(); ++c)
      NetSetup(setup_, fin.x[off + static_cast<int>(c)], m.setup_part[c]);
    off += static_cast<int>(m.cols.size());
  }
  const SetupMean sm = MeanSetup(p_, setup_, fin.sigma2);
  auto entry = [&](EffectId id, std::vector<double> value, std::vector<double> sigma) {
    DiscoveryModelEntry e;
    e.id = id;
    e.effect = Name(id);
    e.unit = effects::Info(id).unit;
    e.value = std::move(value);
    e.sigma = std::move(sigma);
    return e;
  };
  res.final_model.push_back(entry(EffectId::kCentreOffset, {sm.mean[0], sm.mean[1]},
                                  {std::sqrt(sm.var[0]), std::sqrt(sm.var[1])}));
  res.final_model.push_back(entry(EffectId::kRadiusError, {sm.mean[2]}, {std::sqrt(sm.var[2])}));
  off = 0;
  for (const auto& m : model_) {
    const EffectValue v = ValueOf(p_, m, fin, off);
    DiscoveryModelEntry e = entry(m.id, v.value, v.sigma);
    e.shape = ShapeMap(m);
    res.final_model.push_back(std::move(e));
    off += static_cast<int>(m.cols.size());
  }
  res.unexplained_rms_um = Rms(fin.residual);
  res.noise_floor_um = NoiseFloor(p_, fin.residual);
}

DiscoveryResult DiscoveryRun::Run() {
  DiscoveryResult res;
  while (Step(res)) {
  }
  FinalModel(res);
  return res;
}

}  // namespace

DiscoveryResult DiscoverSerialDbb(const std::vector<DiagnosisTrace>& traces, Plane plane,
                                  const DiscoveryOptions& opt) {
  opt.Check();
  if (traces.empty()) throw InvalidInput("", 0, "tests", "no trace to discover from");
  DiscoveryRun run(traces, plane, opt);
  return run.Run();
}

}  // namespace km::dbb
