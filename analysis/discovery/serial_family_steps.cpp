// The per-step parts of the serial family (serial_family.h): physical bounds and variant
// names, refinement of the shape parameters (spike width, cyclic period) when an effect is
// accepted, the evidence of a step for people, and the search around the greedy ladder
// (DiscoverSerial).
#include "analysis/core/angles.h"
#include "analysis/discovery/serial_family.h"
#include "analysis/discovery/serial_family_util.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

namespace km::discovery {
namespace {

using Eigen::VectorXd;
using serial_effects::EffectId;
using util::Format;
using util::IsCyclic;
using util::IsSpike;
using util::Rms;

}  // namespace

double SerialFamily::LowerBound(EffectId id, int j) const {
  if (j != 0) return -std::numeric_limits<double>::infinity();
  switch (id) {
    case EffectId::kBacklashU:
    case EffectId::kBacklashV:
      return opt_.uncompensated_backlash ? 0.0 : -std::numeric_limits<double>::infinity();
    case EffectId::kReversalSpikeU:
    case EffectId::kReversalSpikeV:
    case EffectId::kLateralPlayU:
    case EffectId::kLateralPlayV:
    case EffectId::kStickSlip:
      return 0.0;
    default:
      return -std::numeric_limits<double>::infinity();
  }
}

std::string SerialFamily::VariantOf(const dbb::EffectColumns& sig) const {
  const auto& info = serial_effects::Info(sig.id);
  std::string v;
  for (std::size_t k = 0; k < sig.shape.size(); ++k) {
    if (!v.empty()) v += ", ";
    v += info.param_names[static_cast<std::size_t>(info.num_linear) + k] + " = " +
         Format("%.4g", sig.shape[k]);
  }
  return v;
}

// Golden-section refinement of the shape parameter of every spike and cyclic term from
// `first` on, then of the earlier ones, on the bounded joint residual.
void SerialFamily::RefineShapes(std::vector<Term>& terms, std::size_t first) const {
  if (!opt_.refine_shapes) return;
  std::vector<std::size_t> order;
  for (std::size_t i = first; i < terms.size(); ++i) order.push_back(i);
  for (std::size_t i = 0; i < first && i < terms.size(); ++i) order.push_back(i);
  for (std::size_t idx : order) {
    Term& t = terms[idx];
    const EffectId id = t.sig.id;
    if (!IsSpike(id) && !IsCyclic(id)) continue;
    const double s0 = t.sig.shape[0];
    // Spikes: log-width within a factor 2 either side; periods: half a periodogram bin.
    double lo, hi;
    if (IsSpike(id)) {
      lo = std::log(s0 / 2.0);
      hi = std::log(s0 * 2.0);
    } else {
      const double rel = 0.5 * s0 * dbb::kCyclicBins / (dbb::kCyclicFft * rmin_mm_);
      lo = s0 * (1.0 - std::min(0.1, rel));
      hi = s0 * (1.0 + std::min(0.1, rel));
    }
    auto shape_of = [&](double u) { return IsSpike(id) ? std::exp(u) : u; };
    auto rss = [&](double u) {
      Term trial{dbb::SetupFreeSignature(p_, id, {shape_of(u)}), t.order};
      std::vector<const Term*> ptrs;
      for (std::size_t i = 0; i < terms.size(); ++i) ptrs.push_back(i == idx ? &trial : &terms[i]);
      return Fit(ptrs).rss;
    };
    const double gr = (std::sqrt(5.0) - 1.0) / 2.0;
    double x1 = hi - gr * (hi - lo), x2 = lo + gr * (hi - lo);
    double f1 = rss(x1), f2 = rss(x2);
    for (int it = 0; it < 14; ++it) {
      if (f1 < f2) {
        hi = x2;
        x2 = x1;
        f2 = f1;
        x1 = hi - gr * (hi - lo);
        f1 = rss(x1);
      } else {
        lo = x1;
        x1 = x2;
        f1 = f2;
        x2 = lo + gr * (hi - lo);
        f2 = rss(x2);
      }
    }
    const double best = f1 < f2 ? x1 : x2;
    const double u0 = IsSpike(id) ? std::log(s0) : s0;
    if (std::min(f1, f2) < rss(u0)) t.sig = dbb::SetupFreeSignature(p_, id, {shape_of(best)});
  }
}

Evidence SerialFamily::Describe(const FitState& before, const Candidate& c,
                                const VectorXd& contribution) {
  if (IsDelay(c)) return DescribeDelay(before, contribution);
  Evidence ev;
  const VectorXd gap = -before.residual;  // measured − model
  const Term* term = Find(c);
  const EffectId id = term ? term->sig.id : EffectId::kSquareness;
  const auto& info = serial_effects::Info(id);
  // Even / odd parts over the cw/ccw pairs of one test id (1° bins of the commanded angle).
  constexpr int kBins = 360;
  std::vector<std::vector<double>> sum(traces_.size(), std::vector<double>(kBins, 0.0));
  std::vector<std::vector<int>> cnt(traces_.size(), std::vector<int>(kBins, 0));
  for (int g = 0; g < p_.traces; ++g) {
    const auto t = static_cast<std::size_t>(trace_of_group_[static_cast<std::size_t>(g)]);
    for (std::size_t i = p_.begin[static_cast<std::size_t>(g)];
         i < p_.begin[static_cast<std::size_t>(g) + 1]; ++i) {
      const double th = std::remainder(p_.samples[i].a.theta, 2.0 * std::numbers::pi);
      const int bin = std::clamp(
          static_cast<int>(std::floor((th + std::numbers::pi) / (2.0 * std::numbers::pi) * kBins)),
          0, kBins - 1);
      sum[t][static_cast<std::size_t>(bin)] += gap[static_cast<Eigen::Index>(i)];
      ++cnt[t][static_cast<std::size_t>(bin)];
    }
  }
  double even2 = 0.0, odd2 = 0.0;
  bool paired = false;
  for (std::size_t a = 0; a < traces_.size(); ++a) {
    if (traces_[a].direction != dbb::Direction::kCcw) continue;
    for (std::size_t b = 0; b < traces_.size(); ++b) {
      if (traces_[b].direction != dbb::Direction::kCw || test_ids_[a] != test_ids_[b]) continue;
      paired = true;
      for (int k = 0; k < kBins; ++k) {
        const auto kk = static_cast<std::size_t>(k);
        if (!cnt[a][kk] || !cnt[b][kk]) continue;
        const double ga = sum[a][kk] / cnt[a][kk], gb = sum[b][kk] / cnt[b][kk];
        even2 += 0.25 * (ga + gb) * (ga + gb);
        odd2 += 0.25 * (ga - gb) * (ga - gb);
      }
    }
  }
  const double tot = even2 + odd2;
  const double odd_pct = tot > 0 ? 100.0 * std::sqrt(odd2 / tot) : 0.0;
  const double even_pct = tot > 0 ? 100.0 * std::sqrt(even2 / tot) : 0.0;
  // Share of what the effect explains that lies within 10° of its axis's reversals.
  double near = 0.0, all = 0.0;
  const double rev = info.axis == 1 ? std::numbers::pi / 2.0 : 0.0;
  for (int i = 0; i < p_.n; ++i) {
    const double v = contribution[i] * contribution[i];
    all += v;
    const double d = std::abs(
        std::remainder(p_.samples[static_cast<std::size_t>(i)].a.theta - rev, std::numbers::pi));
    if (d < 10.0 * kDeg) near += v;
  }
  const double near_pct = all > 0 ? 100.0 * near / all : 0.0;
  const double explained =
      gap.squaredNorm() > 0 ? 100.0 * (1.0 - (gap - contribution).squaredNorm() / gap.squaredNorm())
                            : 0.0;
  ev.figures = {{"explained_pct", explained}, {"gap_rms_um", Rms(gap)}};
  if (paired) {
    ev.figures["odd_part_pct"] = odd_pct;
    ev.figures["even_part_pct"] = even_pct;
  }
  if (info.axis >= 0) ev.figures["near_reversal_pct"] = near_pct;
  const auto [first, second] = dbb::AxisLetters(plane_);
  const char axis = info.axis == 1 ? second : first;
  const char other = info.axis == 1 ? first : second;
  const std::string rev_at = info.axis == 1 ? "90° and 270°" : "0° and 180°";
  auto pct = [](double v) { return Format("%.0f %%", v); };
  const std::string parity =
      paired ? " (even part " + pct(even_pct) + ", odd part " + pct(odd_pct) + " of its RMS)" : "";
  std::string why;
  const std::string& base = info.base_name;
  if (base == "squareness") {
    why = "the gap is a 45° ellipse (sin 2θ) alike in cw and ccw" + parity;
  } else if (base == "scale_mismatch") {
    why = "the gap is an ellipse along the axes (cos 2θ) alike in cw and ccw" + parity;
  } else if (base == "servo_mismatch") {
    why = "the gap is a 45° ellipse whose tilt flips between cw and ccw" + parity +
          ", growing with the feed";
  } else if (base == "backlash") {
    why = std::string("the gap steps where ") + axis + " reverses (" + rev_at +
          ") and the step follows the direction of motion; " + pct(near_pct) +
          " of what it explains lies within 10° of those reversals";
  } else if (base == "reversal_spike") {
    why = std::string("the gap has outward spikes just after ") + axis + " reverses (" + rev_at +
          ", decay width " + Format("%.3g", term ? term->sig.shape[0] : 0.0) +
          "°) on the side the motion goes to; " + pct(near_pct) +
          " of what it explains lies within 10° of those reversals";
  } else if (base == "lateral_play") {
    why = std::string("between the reversals of ") + axis + " the gap bulges sideways along " +
          other + ", outward in one direction and inward in the other" + parity +
          ", without a step at the reversal";
  } else if (base == "straightness") {
    why = "the gap has three lobes (3θ) alike in cw and ccw" + parity;
  } else if (base == "cyclic_error") {
    why = std::string("the periodogram of the gap along ") + axis + " peaks at a period of " +
          Format("%.4g", term ? term->sig.shape[0] : 0.0) + " mm";
  } else {
    why = "its signature matches the gap" + parity;
  }
  ev.sentence = c.effect + ": " + why + "; the fitted " + c.effect + " explains " + pct(explained) +
                " of the gap's variance.";

  SerialStepNote note;
  if (const auto it = confused_.find(c.effect); it != confused_.end())
    note.indistinguishable_from = it->second;
  std::sort(note.indistinguishable_from.begin(), note.indistinguishable_from.end());
  notes_.push_back(std::move(note));
  return ev;
}

SerialRun DiscoverSerial(const std::vector<dbb::DiagnosisTrace>& traces,
                         const std::vector<std::string>& test_ids, dbb::Plane plane,
                         const SerialFamilyOptions& options, EngineOptions engine,
                         const ProgressFn& progress) {
  auto run = [&](const SerialFamilyOptions& o) {
    SerialRun r;
    r.family = std::make_unique<SerialFamily>(traces, test_ids, plane, o);
    EngineOptions e = engine;
    e.resolution_um = std::max(e.resolution_um, r.family->ResolutionUm());
    r.result = RunDiscovery(*r.family, e, progress);
    return r;
  };
  SerialRun best = run(options);
  if (best.result.verdict != Verdict::kModelMisfit) return best;
  std::vector<std::string> taken;
  for (const auto& s : best.result.steps) taken.push_back(s.added_effect);
  int tried = 0;
  for (std::size_t i = 0; i < taken.size(); ++i) {
    SerialFamilyOptions o = options;
    o.withheld.emplace_back(static_cast<int>(i) + 1, taken[i]);
    SerialRun alt = run(o);
    ++tried;
    if (alt.result.verdict != Verdict::kComplete) continue;
    const bool better = best.result.verdict != Verdict::kComplete ||
                        alt.result.steps.size() < best.result.steps.size() ||
                        (alt.result.steps.size() == best.result.steps.size() &&
                         alt.result.unexplained_rms_um < best.result.unexplained_rms_um);
    if (!better) continue;
    best = std::move(alt);
    best.alternative = taken[i] + " at step " + std::to_string(i + 1);
  }
  best.alternatives_tried = tried;
  return best;
}

}  // namespace km::discovery
