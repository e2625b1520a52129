// Servo lag in the serial family (serial_family.h): the model's position-dependent errors
// evaluated where the axes are, a delay τ behind their command along the path.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "analysis/core/angles.h"
#include "analysis/discovery/serial_family.h"
#include "analysis/discovery/serial_family_util.h"

namespace km::discovery {
namespace {

using Eigen::VectorXd;
using serial_effects::EffectId;
using util::Format;

constexpr double kGolden = 0.6180339887498949;

// Angular speed (rad/s) times the direction sign of a trace: the angle a delay of 1 s shifts.
double SignedOmega(const dbb::DiagnosisTrace& t) {
  const double s = t.direction == dbb::Direction::kCcw ? 1.0 : -1.0;
  return s * t.feed_mm_min / 60.0 / t.radius_mm;
}

}  // namespace

std::vector<dbb::DiagnosisTrace> SerialFamily::OffReversals(
    std::vector<dbb::DiagnosisTrace> groups) {
  for (auto& g : groups) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < g.angle_rad.size(); ++i) {
      if (serial_effects::internal::AtAxisReversal(g.angle_rad[i])) continue;
      g.angle_rad[kept] = g.angle_rad[i];
      g.dev_um[kept++] = g.dev_um[i];
    }
    g.angle_rad.resize(kept);
    g.dev_um.resize(kept);
    g.cos_angle.clear();
    g.sin_angle.clear();
  }
  return groups;
}

dbb::StackedTraces SerialFamily::StackAt(double delay_ms) const {
  if (delay_ms == 0.0) return dbb::StackTraces(groups_);
  std::vector<dbb::DiagnosisTrace> shifted = groups_;
  for (auto& t : shifted) {
    const double shift = SignedOmega(t) * delay_ms * 1e-3;
    for (double& a : t.angle_rad) a -= shift;
    t.cos_angle.clear();
    t.sin_angle.clear();
  }
  return dbb::StackTraces(shifted);
}

double SerialFamily::DelayRss(double delay_ms) const {
  const auto p = StackAt(delay_ms);
  VectorXd e0 = p.y;
  p.RemoveSetup(e0);
  std::vector<Term> terms;
  for (const auto& t : model_)
    terms.push_back(Term{dbb::SetupFreeSignature(p, t.sig.id, t.sig.shape), t.order});
  std::vector<const Term*> ptrs;
  for (const auto& t : terms) ptrs.push_back(&t);
  return FitTo(e0, ptrs).rss;
}

// −(r(to) − r(from)) / (to − from) with r = e0 − A x at the model's current values x.
VectorXd SerialFamily::DelayColumn(double from_ms, double to_ms) const {
  const auto& fitted = history_.back().effects;
  auto residual = [&](double delay_ms) {
    const auto p = StackAt(delay_ms);
    VectorXd r = p.y;
    p.RemoveSetup(r);
    for (std::size_t i = 0; i < model_.size(); ++i) {
      const auto sig = dbb::SetupFreeSignature(p, model_[i].sig.id, model_[i].sig.shape);
      for (std::size_t j = 0; j < sig.cols.size(); ++j) r -= fitted[i].linear[j] * sig.cols[j];
    }
    return r;
  };
  return -(residual(to_ms) - residual(from_ms)) / (to_ms - from_ms);
}

void SerialFamily::Restack(double delay_ms) {
  delay_ms_ = delay_ms;
  p_ = StackAt(delay_ms);
  e0_ = p_.y;
  p_.RemoveSetup(e0_, &setup_y_);
  for (auto& t : model_) t.sig = dbb::SetupFreeSignature(p_, t.sig.id, t.sig.shape);
}

// Golden section of the bounded refit's RSS over log τ in [lo, hi]; the model is restacked at
// the best delay (kept at the current one when no delay in the bracket fits better).
void SerialFamily::RefineDelay(double lo_ms, double hi_ms) {
  double lo = std::log(std::max(lo_ms, 1e-3)), hi = std::log(std::max(hi_ms, 2e-3));
  double x1 = hi - kGolden * (hi - lo), x2 = lo + kGolden * (hi - lo);
  double f1 = DelayRss(std::exp(x1)), f2 = DelayRss(std::exp(x2));
  for (int it = 0; it < 16; ++it) {
    if (f1 < f2) {
      hi = x2, x2 = x1, f2 = f1, x1 = hi - kGolden * (hi - lo), f1 = DelayRss(std::exp(x1));
    } else {
      lo = x1, x1 = x2, f1 = f2, x2 = lo + kGolden * (hi - lo), f2 = DelayRss(std::exp(x2));
    }
  }
  const double best = std::exp(f1 < f2 ? x1 : x2);
  if (delay_ms_ > 0.0 && DelayRss(delay_ms_) <= std::min(f1, f2)) return;
  Restack(best);
}

void SerialFamily::FinishStep() {
  std::vector<const Term*> ptrs;
  for (const auto& m : model_) ptrs.push_back(&m);
  const Bounded fit = Fit(ptrs);
  if (delay_ms_ > 0.0) {
    // The derivative at the values of this fit (the entry is replaced below).
    history_.push_back(MakeModel(model_, fit));
    const double h = std::max(0.25, 0.05 * delay_ms_);
    delay_col_ = DelayColumn(std::max(0.0, delay_ms_ - h), delay_ms_ + h);
    history_.pop_back();
  }
  history_.push_back(MakeModel(model_, fit));
}

bool SerialFamily::IsDelay(const Candidate& c) const {
  return c.effect == Name(EffectId::kServoLag);
}

// Offered once the model has effects and no delay yet: the secant column to the best delay of
// a coarse scan (2.5 ms … 320 ms), when that delay fits better than none.
std::vector<Candidate> SerialFamily::DelayCandidate(int step) {
  delay_offered_ms_ = 0.0;
  const std::string name = Name(EffectId::kServoLag);
  const bool withheld = std::any_of(opt_.withheld.begin(), opt_.withheld.end(), [&](const auto& w) {
    return w.first == step && w.second == name;
  });
  if (model_.empty() || delay_ms_ > 0.0 || withheld) return {};
  double best = 0.0, best_rss = history_.back().rss_um2;
  for (double d = 2.5; d <= 320.0; d *= 2.0) {
    const double rss = DelayRss(d);
    if (rss < best_rss) best = d, best_rss = rss;
  }
  if (best == 0.0) return {};
  delay_offered_ms_ = best;
  Candidate c;
  c.effect = name;
  c.priority = static_cast<int>(serial_effects::AllEffects().size()) + 1;
  delay_offered_col_ = DelayColumn(0.0, best);
  c.columns = delay_offered_col_;
  c.parameter_names = {"delay_ms"};
  return {c};
}

void SerialFamily::AddDelayEffect(SerialModel& m, double sigma2) const {
  double sigma = 0.0;
  if (delay_col_.size() == p_.n) {
    // σ of τ with the effects' values free: the delay column net of their span.
    VectorXd left = delay_col_;
    std::vector<VectorXd> basis;
    for (const auto& t : model_) {
      for (VectorXd v : t.sig.cols) {
        for (const auto& q : basis) v -= q.dot(v) * q;
        if (v.norm() > 0.0) basis.push_back(v / v.norm());
      }
    }
    for (const auto& q : basis) left -= q.dot(left) * q;
    sigma = left.norm() > 0.0 ? std::sqrt(sigma2) / left.norm() : 0.0;
  }
  SerialEffectFit e;
  e.id = EffectId::kServoLag;
  e.name = Name(EffectId::kServoLag);
  e.unit = "ms";
  e.linear = {delay_ms_};
  e.linear_sigma = {sigma};
  e.value = {delay_ms_};
  e.sigma = {sigma};
  e.z_score = sigma > 0.0 ? std::min(1e9, delay_ms_ / sigma) : 1e9;
  e.parameters = {{"delay_ms", delay_ms_}};
  m.effects.push_back(std::move(e));
}

Evidence SerialFamily::DescribeDelay(const FitState& before, const VectorXd& contribution) const {
  Evidence ev;
  const VectorXd gap = -before.residual;
  const double explained =
      gap.squaredNorm() > 0 ? 100.0 * (1.0 - (gap - contribution).squaredNorm() / gap.squaredNorm())
                            : 0.0;
  // The linear estimate of this step (Describe comes before Accept's refinement).
  const double cc = delay_offered_col_.squaredNorm();
  const double tau = cc > 0.0 && delay_offered_col_.size() == contribution.size()
                         ? delay_offered_col_.dot(contribution) / cc
                         : delay_ms_;
  const auto& t0 = groups_.front();
  const double deg = std::abs(SignedOmega(t0)) * tau * 1e-3 / kDeg;
  ev.figures = {{"explained_pct", explained},
                {"gap_rms_um", gap.size() ? std::sqrt(gap.squaredNorm() / gap.size()) : 0.0},
                {"delay_ms", tau},
                {"lag_deg", deg}};
  ev.sentence = Name(EffectId::kServoLag) +
                ": the model's position-dependent errors fit where the axes are, not where "
                "they were commanded: " +
                Format("%.3g", tau) + " ms behind the command along the path (" +
                Format("%.3g", deg) + "° at " + Format("%.6g", t0.feed_mm_min) + " mm/min on " +
                Format("%.6g", t0.radius_mm) +
                " mm), shifted the opposite way in cw and ccw; a position loop lags by "
                "(1 − K_f)/K_pp (K_pp the position gain, K_f the velocity feed-forward); the "
                "delay explains " +
                Format("%.0f %%", explained) + " of the gap's variance.";
  return ev;
}

}  // namespace km::discovery
