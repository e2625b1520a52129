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
struct EffectValue {
  std::vector<double> params;
  std::vector<double> value;
  std::vector<double> sigma;
  double z = 0.0;
  bool two_value = false;
};

EffectValue ValueOf(const StackedTraces& p, const EffectColumns& e, const Refit& r, int off) {
  const auto& info = effects::Info(e.id);
  const int nl = info.num_linear;
  EffectValue v;
  v.params.assign(static_cast<std::size_t>(info.num_params), 0.0);
  for (int m = 0; m < nl; ++m) v.params[static_cast<std::size_t>(m)] = r.x[off + m];
  for (std::size_t k = 0; k < e.shape.size(); ++k)
    v.params[static_cast<std::size_t>(nl) + k] = e.shape[k];
  const auto& ctx = p.ctx[0];
  v.value = effects::Value(e.id, ctx, v.params.data());
  const MatrixXd jac = effects::ValueJacobian(e.id, ctx, v.params.data()).leftCols(nl);
  const MatrixXd cv = jac * r.cov.block(off, off, nl, nl) * jac.transpose();
  double vnorm = 0.0, snorm = 0.0;
  for (std::size_t m = 0; m < v.value.size(); ++m) {
    const auto mi = static_cast<Eigen::Index>(m);
    const double s = std::sqrt(std::max(0.0, cv(mi, mi)));
    v.sigma.push_back(s);
    vnorm += v.value[m] * v.value[m];
    snorm += s * s;
  }
  // Same z as the diagnosis: norm of the values over the RMS of their σ; finite when σ = 0.
  v.z = snorm > 0.0 ? std::sqrt(vnorm / (snorm / static_cast<double>(v.value.size())))
                    : (vnorm > 0.0 ? 1e9 : 0.0);
  v.z = std::min(v.z, 1e9);
  v.two_value = v.value.size() > 1 || nl > 1;
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

double RegularizedIncompleteBeta(double a, double b, double x) {
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

DiscoveryResult DiscoverSerialDbb(const std::vector<DiagnosisTrace>& traces, Plane plane,
                                  const DiscoveryOptions& opt) {
  opt.Check();
  if (traces.empty()) throw InvalidInput("", 0, "tests", "no trace to discover from");
  const auto [first, second] = AxisLetters(plane);
  const StackedTraces p = StackTraces(traces);
  // The letters are copied into the lambda: capturing structured bindings needs clang 16.
  auto name = [a = first, b = second](EffectId id) { return effects::EffectName(id, a, b); };

  // Model 0: the set-up terms (least-squares circle of each trace); e0 = the gap about it.
  VectorXd e0 = p.y;
  std::vector<Eigen::Vector3d> setup;
  p.RemoveSetup(e0, &setup);

  // Candidates: the registry's linear form effects (list order = priority), fixed shapes built
  // once; spikes in every width of the set; cyclic errors per step from the current gap.
  std::vector<Variant> fixed;
  std::vector<EffectId> cyclic_ids;
  {
    int order = 0;
    for (const auto& info : effects::AllEffects()) {
      ++order;
      if (!info.in_form || !info.linear_fit) continue;
      if (IsCyclic(info.id)) {
        if (opt.search_cyclic) cyclic_ids.push_back(info.id);
        continue;
      }
      if (IsSpike(info.id)) {
        for (double w : opt.spike_widths_deg)
          fixed.push_back(Variant{SetupFreeSignature(p, info.id, {w}), order});
      } else {
        fixed.push_back(Variant{SetupFreeSignature(p, info.id, {}), order});
      }
    }
  }
  double rmin = std::numeric_limits<double>::infinity(), max_step = 0.0;
  for (const auto& tr : traces) {
    rmin = std::min(rmin, tr.radius_mm);
    for (std::size_t i = 1; i < tr.angle_rad.size(); ++i)
      max_step = std::max(max_step, std::abs(tr.angle_rad[i] - tr.angle_rad[i - 1]));
  }
  const double pmin = std::max(opt.cyclic_min_period_mm, 4.0 * rmin * max_step);
  const double pmax = opt.cyclic_max_period_fraction * rmin;

  // The signatures are first order in e/R: the bar length |P + e − F| − |P − F| = e·n +
  // |e_t|²/(2R) + …; below that second-order term a "gap" is geometry, not an effect.
  const double linearisation_um =
      e0.cwiseAbs().maxCoeff() * e0.cwiseAbs().maxCoeff() / (2.0 * rmin * 1000.0);
  DiscoveryResult res;
  std::vector<EffectColumns> model;  // accepted effects, in step order
  std::vector<VectorXd> basis;       // orthonormal basis of their columns
  VectorXd gap = e0;
  Refit current = JointRefit(p, {}, e0);

  while (true) {
    auto in_model = [&](EffectId id) {
      return std::any_of(model.begin(), model.end(), [&](const auto& m) { return m.id == id; });
    };
    // This step's variants: the fixed ones not in the model, plus cyclic errors at the period
    // of the strongest peak of the current gap (refined by golden section).
    std::vector<const Variant*> variants;
    std::vector<Variant> cyclic;
    cyclic.reserve(cyclic_ids.size());
    for (const auto& v : fixed)
      if (!in_model(v.sig.id)) variants.push_back(&v);
    if (pmax > pmin) {
      for (EffectId id : cyclic_ids) {
        if (in_model(id)) continue;
        const int axis = id == EffectId::kCyclicErrorU ? 0 : 1;
        double period = CyclicPeriodPeak(p, gap, axis, pmin, pmax);
        if (!(period > 0.0)) continue;
        const double bin_rel = 2.0 * period * kCyclicBins / (2.0 * kCyclicFft * rmin);
        period = RefinePeriod(p, gap, axis, period, std::min(0.2, bin_rel), rmin * max_step);
        const int order = static_cast<int>(id) + 1;
        cyclic.push_back(Variant{SetupFreeSignature(p, id, {period}), order});
      }
    }
    for (const auto& v : cyclic) variants.push_back(&v);

    // Try every variant: identifiability against the model, RSS drop.
    std::vector<Trial> trials;
    res.not_identifiable.clear();
    for (std::size_t k = 0; k < variants.size(); ++k) {
      const EffectColumns& sig = variants[k]->sig;
      Trial t;
      t.variant = k;
      for (const auto& col : sig.cols) {
        VectorXd v = col;
        Reduce(basis, v);
        Reduce(t.q, v);
        const double left = v.squaredNorm(), full = col.squaredNorm();
        if (!(full > 0.0) || left < opt.confound_ratio * opt.confound_ratio * full) {
          t.identifiable = false;
          // The model effect most correlated with this signature.
          double best = -1.0;
          for (const auto& m : model) {
            for (const auto& mc : m.cols) {
              const double corr =
                  std::abs(mc.dot(col)) / std::sqrt(mc.squaredNorm() * full + 1e-300);
              if (corr > best) {
                best = corr;
                t.confounded_with = name(m.id);
              }
            }
          }
          break;
        }
        t.q.push_back(v / std::sqrt(left));
      }
      if (t.identifiable) {
        for (const auto& q : t.q) t.drop += std::pow(q.dot(gap), 2);
      } else {
        const std::string s = name(sig.id) + (t.confounded_with.empty()
                                                  ? std::string()
                                                  : " (confounded with " + t.confounded_with + ")");
        if (std::find(res.not_identifiable.begin(), res.not_identifiable.end(), s) ==
            res.not_identifiable.end())
          res.not_identifiable.push_back(s);
      }
      trials.push_back(std::move(t));
    }
    const double gap_rms = Rms(gap);
    const double floor = std::max({NoiseFloor(p, gap), opt.resolution_um, linearisation_um});
    if (gap_rms <= (1.0 + opt.noise_stop_fraction) * floor) {
      res.stop_reason = "the gap is at the noise floor";
      break;
    }
    if (static_cast<int>(res.steps.size()) >= opt.max_steps) {
      res.stop_reason = "maximum number of steps";
      break;
    }
    const Trial* best = nullptr;
    for (const auto& t : trials)
      if (t.identifiable && (!best || t.drop > best->drop)) best = &t;
    if (!best) {
      res.stop_reason = "no identifiable candidate left";
      break;
    }
    // Candidates the data cannot tell from the best one given the model (their projected
    // signature lies within the confound ratio of the best one's): the earliest in the registry
    // list is taken (the diagnosis priority rule), the others are named in the evidence.
    std::vector<const Trial*> confused;
    const EffectId best_id = variants[best->variant]->sig.id;
    for (const auto& t : trials) {
      if (!t.identifiable || &t == best || variants[t.variant]->sig.id == best_id) continue;
      // Mutual: each projected signature lies within the other's span up to the ratio.
      auto within = [&](const std::vector<VectorXd>& a, const std::vector<VectorXd>& b) {
        for (const auto& q : a) {
          VectorXd v = q;
          Reduce(b, v);
          if (v.squaredNorm() >= opt.confound_ratio * opt.confound_ratio) return false;
        }
        return true;
      };
      if (within(t.q, best->q) && within(best->q, t.q)) confused.push_back(&t);
    }
    const Trial* chosen = best;
    for (const Trial* t : confused)
      if (variants[t->variant]->order < variants[chosen->variant]->order) chosen = t;
    const EffectColumns& csig = variants[chosen->variant]->sig;
    std::vector<std::string> indistinguishable;
    for (const Trial* t : confused) {
      if (t == chosen) continue;
      indistinguishable.push_back(name(variants[t->variant]->sig.id));
    }
    if (chosen != best) indistinguishable.push_back(name(best_id));
    std::sort(indistinguishable.begin(), indistinguishable.end());
    indistinguishable.erase(std::unique(indistinguishable.begin(), indistinguishable.end()),
                            indistinguishable.end());
    // Runner-up: the best other effect (any shape) at this step.
    const Trial* runner = nullptr;
    for (const auto& t : trials) {
      if (!t.identifiable || variants[t.variant]->sig.id == csig.id) continue;
      if (!runner || t.drop > runner->drop) runner = &t;
    }

    // Joint refit with the candidate, F-test and value.
    std::vector<const EffectColumns*> cols;
    for (const auto& m : model) cols.push_back(&m);
    cols.push_back(&csig);
    const Refit after = JointRefit(p, cols, e0);
    const int q = static_cast<int>(csig.cols.size());
    DiscoveryStep step;
    step.id = csig.id;
    step.added_effect = name(csig.id);
    auto& ev = step.evidence;
    ev.rss_before_um2 = current.rss;
    ev.rss_after_um2 = after.rss;
    ev.df_numerator = q;
    ev.df_denominator = after.dof;
    const double drop = std::max(0.0, current.rss - after.rss);
    ev.f_statistic = after.rss > 0.0 ? (drop / q) / (after.rss / after.dof)
                                     : (drop > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
    const double log_p = LogFUpperTail(ev.f_statistic, q, after.dof);
    ev.p_value = std::exp(log_p);
    ev.log10_p_value = std::isinf(log_p) ? -1e9 : log_p / std::log(10.0);
    ev.f_statistic = std::min(ev.f_statistic, 1e300);
    const EffectValue val = ValueOf(p, csig, after, static_cast<int>(after.x.size()) - q);
    ev.value = val.value;
    ev.sigma = val.sigma;
    ev.unit = effects::Info(csig.id).unit;
    ev.z_score = val.z;
    ev.parameters = ParameterMap(csig, val);
    if (runner) {
      ev.runner_up = name(variants[runner->variant]->sig.id);
      ev.runner_up_rss_drop_um2 = runner->drop;
    }
    ev.indistinguishable_from = indistinguishable;
    step.gap_rms_before_um = gap_rms;
    step.gap_rms_after_um = Rms(after.residual);

    const double z_needed = val.two_value ? opt.significance + 1.0 : opt.significance;
    const bool significant_f = log_p < std::log(opt.max_p_value);
    const bool significant_z = val.z > z_needed;
    if (!significant_f || !significant_z) {
      char buf[256];
      std::snprintf(buf, sizeof buf, "%s (p = %.3g, |value|/sigma = %.3g: %s)",
                    step.added_effect.c_str(), ev.p_value, val.z,
                    !significant_f ? "F-test not significant" : "value not significant");
      res.rejected.push_back(buf);
      res.stop_reason = "the best candidate is not significant";
      break;
    }
    // Accept: the candidate joins the model.
    for (const auto& qv : chosen->q) basis.push_back(qv);
    model.push_back(csig);
    current = after;
    gap = after.residual;
    res.steps.push_back(std::move(step));
  }

  // Final model: set-up terms net of the accepted effects' own set-up parts, then the effects.
  std::vector<const EffectColumns*> cols;
  for (const auto& m : model) cols.push_back(&m);
  const Refit fin = JointRefit(p, cols, e0);
  {
    int off = 0;
    for (const auto& m : model) {
      for (std::size_t c = 0; c < m.cols.size(); ++c) {
        for (std::size_t t = 0; t < setup.size(); ++t)
          setup[t] -= fin.x[off + static_cast<int>(c)] * m.setup_part[c][t];
      }
      off += static_cast<int>(m.cols.size());
    }
    Eigen::Vector3d mean = Eigen::Vector3d::Zero(), var = Eigen::Vector3d::Zero();
    for (int t = 0; t < p.traces; ++t) {
      mean += setup[static_cast<std::size_t>(t)];
      var += fin.sigma2 * p.setup_inv[static_cast<std::size_t>(t)].diagonal();
    }
    const double tt = p.traces;
    mean /= tt;
    var /= tt * tt;
    DiscoveryModelEntry c;
    c.id = EffectId::kCentreOffset;
    c.effect = name(c.id);
    c.unit = effects::Info(c.id).unit;
    c.value = {mean[0], mean[1]};
    c.sigma = {std::sqrt(var[0]), std::sqrt(var[1])};
    res.final_model.push_back(c);
    DiscoveryModelEntry r;
    r.id = EffectId::kRadiusError;
    r.effect = name(r.id);
    r.unit = effects::Info(r.id).unit;
    r.value = {mean[2]};
    r.sigma = {std::sqrt(var[2])};
    res.final_model.push_back(r);
    off = 0;
    for (const auto& m : model) {
      const EffectValue v = ValueOf(p, m, fin, off);
      DiscoveryModelEntry e;
      e.id = m.id;
      e.effect = name(m.id);
      e.unit = effects::Info(m.id).unit;
      e.value = v.value;
      e.sigma = v.sigma;
      e.shape = ShapeMap(m);
      res.final_model.push_back(std::move(e));
      off += static_cast<int>(m.cols.size());
    }
  }
  res.unexplained_rms_um = Rms(fin.residual);
  res.noise_floor_um = NoiseFloor(p, fin.residual);
  return res;
}

}  // namespace km::dbb
