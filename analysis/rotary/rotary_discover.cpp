#include "analysis/rotary/rotary_discover.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "analysis/core/angles.h"
#include "analysis/core/option_check.h"
#include "analysis/core/statistics.h"

namespace km::rotary {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

std::vector<std::size_t> FreeOf(const std::vector<RotaryEffect>& named,
                                std::optional<RotaryEffect> extra) {
  std::vector<std::size_t> free;
  for (std::size_t j = 0; j < kLocationErrorCount; ++j) free.push_back(j);
  auto add = [&](RotaryEffect e) {
    const ParameterRange r = EffectRange(e);
    for (std::size_t j = 0; j < r.count; ++j) free.push_back(r.first + j);
  };
  for (RotaryEffect e : named) add(e);
  if (extra) add(*extra);
  std::sort(free.begin(), free.end());
  return free;
}

CandidateTrial Try(const EffectPoses& p, const EffectFit& current,
                   const std::vector<RotaryEffect>& named, RotaryEffect e, const DiscoverOptions& o,
                   EffectFit& fit) {
  CandidateTrial t;
  t.effect = e;
  fit = FitEffects(p, FreeOf(named, e));
  t.added_rank = fit.rank > current.rank ? fit.rank - current.rank : 0;
  t.rms_after_um = fit.rms_um;
  const double dof = double(p.measured_um.size()) - double(fit.rank);
  const double drop = current.rss - fit.rss;
  if (t.added_rank == 0 || dof <= 0.0 || !(drop > 0.0)) return t;
  const double q = double(t.added_rank), s2 = fit.rss / dof;
  t.f = (drop / q) / s2;
  t.p_value = std::exp(LogFUpperTail(t.f, q, dof));
  t.significant = t.p_value < o.false_alarm;
  t.practical = drop > o.practical_factor * q * s2;
  return t;
}

std::string Fixed(double v, int digits) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

// The share of the rest's sum of squares that harmonics 1–4 of c (with a constant) follow.
double HarmonicShare(const EffectPoses& p, const VectorXd& r) {
  const Index n = Index(p.c_rad.size());
  double explained = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    MatrixXd a(n, 9);
    VectorXd b(n);
    for (Index i = 0; i < n; ++i) {
      const double c = p.c_rad[std::size_t(i)];
      a(i, 0) = 1.0;
      for (int k = 1; k <= 4; ++k) {
        a(i, 2 * k - 1) = std::cos(k * c);
        a(i, 2 * k) = std::sin(k * c);
      }
      b(i) = r(3 * i + axis);
    }
    const VectorXd fit = a * a.colPivHouseholderQr().solve(b);
    explained += fit.squaredNorm();
  }
  return r.squaredNorm() > 0.0 ? explained / r.squaredNorm() : 0.0;
}

std::string DescribeMisfit(const EffectPoses& p, const EffectFit& f, Kinematics k, double noise) {
  const VectorXd& r = f.residual_um;
  std::size_t worst = 0;
  for (std::size_t i = 0; i < p.c_rad.size(); ++i) {
    if (r.segment<3>(Index(3 * i)).norm() > r.segment<3>(Index(3 * worst)).norm()) worst = i;
  }
  return "the rest (RMS " + Fixed(f.rms_um, 2) + " µm) is above the noise (" + Fixed(noise, 2) +
         " µm) and no candidate explains it: largest at " + TiltLetter(k) + " = " +
         Fixed(p.tilt_rad[worst] / kDeg, 1) + "°, C = " + Fixed(p.c_rad[worst] / kDeg, 1) + "° (" +
         Fixed(r.segment<3>(Index(3 * worst)).norm(), 2) + " µm); harmonics 1–4 of C follow " +
         Fixed(100.0 * HarmonicShare(p, r), 0) + " % of it";
}

}  // namespace

void DiscoverOptions::Check() const {
  KM_OPTION_IN_OPEN(false_alarm, 0.0, 1.0);
  KM_OPTION_GT(practical_factor, 0.0);
  KM_OPTION_GT(misfit_factor, 1.0);
}

RotaryDiscovery DiscoverRotaryEffects(const RotaryTest& test, const std::vector<double>& time_s,
                                      std::optional<double> noise_um, const DiscoverOptions& o) {
  o.Check();
  const EffectPoses p = PrepareEffectPoses(test, time_s);
  RotaryDiscovery out;
  out.kinematics = test.setup.kinematics;
  out.noise_um = noise_um;
  out.has_time = !time_s.empty() && time_s.back() != time_s.front();
  EffectFit current = FitEffects(p, FreeOf({}, std::nullopt));
  const double first_rms = std::sqrt(p.measured_um.squaredNorm() / double(p.measured_um.size()));
  out.steps.push_back(DiscoverStep{std::nullopt, first_rms, current.rms_um, current.s_um, {}});
  for (;;) {
    DiscoverStep step{std::nullopt, current.rms_um, current.rms_um, current.s_um, {}};
    EffectFit best_fit;
    for (RotaryEffect e : kRotaryEffects) {
      if (std::find(out.named.begin(), out.named.end(), e) != out.named.end()) continue;
      if (e == RotaryEffect::kDrift && !out.has_time) continue;
      EffectFit fit;
      step.candidates.push_back(Try(p, current, out.named, e, o, fit));
      const CandidateTrial& t = step.candidates.back();
      if (t.significant && t.practical && (!step.named || fit.rss < best_fit.rss)) {
        step.named = e;
        best_fit = fit;
      }
    }
    if (!step.named) {
      out.steps.push_back(step);
      break;
    }
    out.named.push_back(*step.named);
    current = best_fit;
    step.rms_after_um = current.rms_um;
    step.s_um = current.s_um;
    out.steps.push_back(step);
  }
  out.final_fit = current;
  if (!noise_um || !(*noise_um > 0.0)) {
    out.verdict = "no noise level";
  } else if (current.s_um <= o.misfit_factor * *noise_um) {
    out.verdict = "complete";
  } else {
    out.verdict = "model misfit";
    out.misfit = DescribeMisfit(p, current, out.kinematics, *noise_um);
  }
  return out;
}

}  // namespace km::rotary
