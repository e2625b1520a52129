#include "analysis/discovery/hexapod_family.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>

#include <Eigen/Geometry>

#include "analysis/core/errors.h"

namespace km::discovery {
namespace {

using Eigen::VectorXd;

}  // namespace

EngineOptions HexapodEngineOptions() {
  EngineOptions o;
  o.cluster_inference = true;
  o.determined_t = 10.0;
  return o;
}

HexapodFamily::HexapodFamily(const hexapod::EffectFitData& data,
                             std::vector<hexapod::ActiveEffect> known)
    : data_(data), pairs_(data), known_(std::move(known)) {}

FitState HexapodFamily::StateOf(const hexapod::EffectFitResult& r) const {
  FitState s;
  s.residual = r.residual_um;
  s.jacobian = r.jacobian;
  s.column_group = r.column_test;
  s.row_begin = data_.row_begin;
  for (const auto& e : r.effects) s.in_model.push_back(e.effect->Name());
  return s;
}

FitState HexapodFamily::FitBase() {
  hexapod::EffectFitResult start = hexapod::StartingPoint(data_, {});
  start.effects = known_;
  history_.push_back(hexapod::FitWithEffects(data_, start));
  return StateOf(history_.back());
}

std::vector<Candidate> HexapodFamily::Candidates(const FitState&) {
  const auto& fit = history_.back();
  pending_.clear();
  std::vector<Candidate> out;
  int priority = 0;
  for (const auto* e : hexapod::HexapodEffects()) {
    ++priority;
    const bool present = std::any_of(fit.effects.begin(), fit.effects.end(),
                                     [&](const auto& a) { return a.effect == e; });
    if (present) continue;
    for (const auto& v : e->Variants(data_.prepared.setup)) {
      Pending p;
      p.effect = hexapod::ActiveEffect{e, v.params};
      for (int k = 0; k < static_cast<int>(v.params.size()); ++k) {
        const bool held = std::find(v.held.begin(), v.held.end(), k) != v.held.end();
        if (v.params[static_cast<std::size_t>(k)].free && !held) p.free.push_back(k);
      }
      p.key = std::string(e->Name()) + "|" + v.label;
      Candidate c;
      c.effect = e->Name();
      c.variant = v.label;
      c.priority = priority;
      c.offset = hexapod::EffectContribution(data_, fit, p.effect);
      c.columns.resize(c.offset.size(), static_cast<int>(p.free.size()));
      for (std::size_t k = 0; k < p.free.size(); ++k) {
        const auto& par = p.effect.params[static_cast<std::size_t>(p.free[k])];
        const double h = std::max(std::abs(par.value), par.scale);
        hexapod::ActiveEffect plus = p.effect;
        plus.params[static_cast<std::size_t>(p.free[k])].value += h;
        c.columns.col(static_cast<int>(k)) =
            (hexapod::EffectContribution(data_, fit, plus) - c.offset) / h;
        c.parameter_names.push_back(par.name);
      }
      pending_.push_back(std::move(p));
      out.push_back(std::move(c));
    }
  }
  return out;
}

const HexapodFamily::Pending* HexapodFamily::Find(const Candidate& c) const {
  const std::string key = c.effect + "|" + c.variant;
  for (const auto& p : pending_)
    if (p.key == key) return &p;
  return nullptr;
}

bool HexapodFamily::Physical(const Candidate& c, const Eigen::VectorXd& x, std::string* why) {
  const Pending* p = Find(c);
  if (!p) return false;
  for (std::size_t k = 0; k < p->free.size(); ++k) {
    const auto& par = p->effect.params[static_cast<std::size_t>(p->free[k])];
    const double v = par.value + x[static_cast<int>(k)];
    if (v < par.lower || v > par.upper) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "%s = %.4g outside [%g, %g]", par.name.c_str(), v, par.lower,
                    par.upper);
      *why = buf;
      return false;
    }
  }
  return true;
}

FitState HexapodFamily::Accept(const Candidate& c, const Eigen::VectorXd& x) {
  const Pending* p = Find(c);
  if (!p) throw DidNotConverge("discovery: unknown candidate " + c.effect);
  hexapod::ActiveEffect a = p->effect;
  for (std::size_t k = 0; k < p->free.size(); ++k) {
    auto& par = a.params[static_cast<std::size_t>(p->free[k])];
    par.value = std::clamp(par.value + x[static_cast<int>(k)], par.lower, par.upper);
  }
  hexapod::EffectFitResult start = history_.back();
  start.effects.push_back(a);
  history_.push_back(hexapod::FitWithEffects(data_, start));
  return StateOf(history_.back());
}

std::vector<int> HexapodFamily::FoldKeys() const {
  std::map<std::string, int> ids;
  std::vector<int> keys;
  for (const auto& t : data_.problem.tests) {
    const auto it = ids.emplace(t.test_id, static_cast<int>(ids.size())).first;
    keys.push_back(it->second);
  }
  return keys;
}

// The gap per tool (RMS): how the gap depends on the tool.
void HexapodFamily::AddToolFigures(const Eigen::VectorXd& gap,
                                   std::map<std::string, double>& figures) const {
  const auto& tests = data_.problem.tests;
  std::map<double, std::pair<double, int>> per_tool;
  for (std::size_t t = 0; t < tests.size(); ++t) {
    const int r0 = data_.row_begin[t], r1 = data_.row_begin[t + 1];
    auto& pt = per_tool[tests[t].tool_length_mm];
    pt.first += gap.segment(r0, r1 - r0).squaredNorm();
    pt.second += r1 - r0;
  }
  for (const auto& [tool, acc] : per_tool) {
    char key[64];
    std::snprintf(key, sizeof key, "gap_rms_tool_%g_um", tool);
    figures[key] = acc.second > 0 ? std::sqrt(acc.first / acc.second) : 0.0;
  }
}

double HexapodFamily::RepeatabilityFloor(const FitState& fit) const {
  return PairRepeatability(pairs_, fit.residual);
}

Evidence HexapodFamily::DescribeGap(const FitState& fit) const {
  const VectorXd gap = -fit.residual;
  const GapFigures g = DescribeGapFigures(data_, pairs_, gap);
  Evidence ev;
  ev.figures = g.figures;
  AddToolFigures(gap, ev.figures);
  const double rms = gap.size() ? std::sqrt(gap.squaredNorm() / gap.size()) : 0.0;
  ev.sentence = MisfitSentence(g, rms, RepeatabilityFloor(fit));
  for (std::size_t k = 0; k < g.worst_tests.size(); ++k)
    ev.figures["worst_test_" + std::to_string(k + 1) + "_rms_um"] = g.worst_tests[k].second;
  return ev;
}

// Why this effect, in words chosen from the figures of the gap it is fitted to.
Evidence HexapodFamily::Describe(const FitState& before, const Candidate& c,
                                 const Eigen::VectorXd& contribution) {
  Evidence ev;
  const VectorXd gap = -before.residual;  // measured − model
  const GapFigures g = DescribeGapFigures(data_, pairs_, gap);
  ev.figures = g.figures;
  AddToolFigures(gap, ev.figures);
  std::vector<double> rms, contrib_rms;
  for (std::size_t t = 0; t + 1 < data_.row_begin.size(); ++t) {
    rms.push_back(SegmentRms(gap, data_.row_begin[t], data_.row_begin[t + 1]));
    contrib_rms.push_back(SegmentRms(contribution, data_.row_begin[t], data_.row_begin[t + 1]));
  }
  const double r_fit = Correlation(rms, contrib_rms);
  const double explained =
      gap.squaredNorm() > 0 ? 100.0 * (1.0 - (gap - contribution).squaredNorm() / gap.squaredNorm())
                            : 0.0;
  ev.figures["explained_pct"] = explained;
  ev.figures["per_test_pattern_match"] = r_fit;
  const auto& f = ev.figures;
  std::string why = "the gap is " + ParityWords(f.at("even_part_pct"), f.at("odd_part_pct"));
  if (c.effect == "gravity_deflection") {
    why += ", and its size per test " + FollowsWords("|tilt|", f.at("correlation_with_tilt"));
  } else if (c.effect == "thermal_drift") {
    why +=
        ", and its size per test " + FollowsWords("the test time", f.at("correlation_with_time"));
  } else {
    why += ", and its size per test " + FollowsWords("the effect's own prediction", r_fit);
  }
  char tail[240];
  std::snprintf(tail, sizeof tail, "; the fitted %s%s%s%s explains %.0f %% of the gap's variance",
                c.effect.c_str(), c.variant.empty() ? "" : " (", c.variant.c_str(),
                c.variant.empty() ? "" : ")", explained);
  const auto* effect = hexapod::FindHexapodEffect(c.effect);
  ev.sentence = std::string(effect ? effect->Signature() : "") + ": " + why + tail + ".";
  ev.sentence[0] = static_cast<char>(std::toupper(ev.sentence[0]));
  return ev;
}

}  // namespace km::discovery
