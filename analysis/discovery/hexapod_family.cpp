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

std::string VariantOf(const hexapod::ActiveEffect& a, int shape) {
  if (shape < 0) return "";
  char buf[96];
  std::snprintf(buf, sizeof buf, "%s = %g", a.params[static_cast<std::size_t>(shape)].name.c_str(),
                a.params[static_cast<std::size_t>(shape)].value);
  return buf;
}

double Correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const std::size_t n = a.size();
  if (n < 3) return 0.0;
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < n; ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= n;
  mb /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

double SegmentRms(const VectorXd& v, int r0, int r1) {
  return r1 > r0 ? std::sqrt(v.segment(r0, r1 - r0).squaredNorm() / (r1 - r0)) : 0.0;
}

}  // namespace

HexapodFamily::HexapodFamily(const hexapod::EffectFitData& data,
                             std::vector<hexapod::ActiveEffect> known)
    : data_(data), known_(std::move(known)) {}

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
    const auto params = e->Parameters(data_.prepared.setup);
    if (params.empty()) continue;
    std::vector<double> grid = e->ShapeGrid();
    const int shape = e->ShapeParameter();
    if (shape < 0 || grid.empty()) grid = {0.0};
    for (double g : grid) {
      Pending p;
      p.effect = hexapod::ActiveEffect{e, params};
      if (shape >= 0) p.effect.params[static_cast<std::size_t>(shape)].value = g;
      for (int k = 0; k < static_cast<int>(params.size()); ++k)
        if (params[static_cast<std::size_t>(k)].free && k != shape) p.free.push_back(k);
      p.key = std::string(e->Name()) + "|" + VariantOf(p.effect, shape);
      Candidate c;
      c.effect = e->Name();
      c.variant = VariantOf(p.effect, shape);
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

// The gap per tool (RMS) and its strongest harmonic order over the circle (1–8, power summed
// over the tests): how the gap depends on the tool and on the angle.
void HexapodFamily::AddToolAndHarmonicFigures(const Eigen::VectorXd& gap,
                                              std::map<std::string, double>& figures) const {
  const auto& tests = data_.problem.tests;
  std::map<double, std::pair<double, int>> per_tool;
  std::array<double, 9> power{};
  for (std::size_t t = 0; t < tests.size(); ++t) {
    const int r0 = data_.row_begin[t], r1 = data_.row_begin[t + 1];
    auto& pt = per_tool[tests[t].tool_length_mm];
    pt.first += gap.segment(r0, r1 - r0).squaredNorm();
    pt.second += r1 - r0;
    const auto& path = data_.prepared.paths[t];
    for (int k = 1; k <= 8; ++k) {
      double a = 0.0, b = 0.0;
      for (int r = r0; r < r1; ++r) {
        const Eigen::Vector3d v =
            path.pose[static_cast<std::size_t>(r - r0)].tip_mm - tests[t].fixed_ball_mm;
        const double th = std::atan2(v.y(), v.x());
        a += gap[r] * std::cos(k * th);
        b += gap[r] * std::sin(k * th);
      }
      const double n = std::max(1, r1 - r0);
      power[static_cast<std::size_t>(k)] += (a * a + b * b) * 4.0 / (n * n);
    }
  }
  for (const auto& [tool, acc] : per_tool) {
    char key[64];
    std::snprintf(key, sizeof key, "gap_rms_tool_%g_um", tool);
    figures[key] = acc.second > 0 ? std::sqrt(acc.first / acc.second) : 0.0;
  }
  const auto strongest = std::max_element(power.begin() + 1, power.end()) - power.begin();
  figures["strongest_harmonic_order"] = static_cast<double>(strongest);
}

Evidence HexapodFamily::Describe(const FitState& before, const Candidate& c,
                                 const Eigen::VectorXd& contribution) {
  Evidence ev;
  const auto& tests = data_.problem.tests;
  const auto& paths = data_.prepared.paths;
  const VectorXd gap = -before.residual;  // measured − model
  // Even / odd parts over CW/CCW pairs at matching angles (nearest sample of the partner).
  std::map<std::string, std::pair<int, int>> pair;  // test_id → (ccw, cw)
  for (std::size_t t = 0; t < tests.size(); ++t) {
    auto& pr = pair.emplace(tests[t].test_id, std::make_pair(-1, -1)).first->second;
    (tests[t].direction == dbb::Direction::kCcw ? pr.first : pr.second) = static_cast<int>(t);
  }
  double even2 = 0.0, odd2 = 0.0;
  for (const auto& [id, pr] : pair) {
    if (pr.first < 0 || pr.second < 0) continue;
    const int a0 = data_.row_begin[pr.first], b0 = data_.row_begin[pr.second];
    const int na = data_.row_begin[pr.first + 1] - a0, nb = data_.row_begin[pr.second + 1] - b0;
    for (int i = 0; i < na; ++i) {
      const double ang =
          std::atan2(paths[pr.first].pose[i].tip_mm.y() - tests[pr.first].fixed_ball_mm.y(),
                     paths[pr.first].pose[i].tip_mm.x() - tests[pr.first].fixed_ball_mm.x());
      int best = 0;
      double bd = 1e9;
      for (int k = 0; k < nb; k += 1) {
        const auto& q = paths[pr.second].pose[k].tip_mm;
        const double d =
            std::abs(std::remainder(std::atan2(q.y() - tests[pr.second].fixed_ball_mm.y(),
                                               q.x() - tests[pr.second].fixed_ball_mm.x()) -
                                        ang,
                                    2.0 * M_PI));
        if (d < bd) {
          bd = d;
          best = k;
        }
      }
      const double ga = gap[a0 + i], gb = gap[b0 + best];
      even2 += 0.25 * (ga + gb) * (ga + gb);
      odd2 += 0.25 * (ga - gb) * (ga - gb);
    }
  }
  const double tot = even2 + odd2;
  const double odd_pct = tot > 0 ? 100.0 * std::sqrt(odd2 / tot) : 0.0;
  const double even_pct = tot > 0 ? 100.0 * std::sqrt(even2 / tot) : 0.0;
  // Dependence of each test's gap on tilt, time and tool.
  std::vector<double> rms, tilt, time, contrib_rms;
  for (std::size_t t = 0; t < tests.size(); ++t) {
    const int r0 = data_.row_begin[t], r1 = data_.row_begin[t + 1];
    rms.push_back(SegmentRms(gap, r0, r1));
    contrib_rms.push_back(SegmentRms(contribution, r0, r1));
    const auto& abc = paths[t].pose.front().abc_rad;
    tilt.push_back(std::hypot(abc.x(), abc.y()) * 180.0 / M_PI);
    time.push_back(paths[t].time_s.front());
  }
  const double r_tilt = Correlation(rms, tilt), r_time = Correlation(rms, time);
  const double r_fit = Correlation(rms, contrib_rms);
  const double explained =
      gap.squaredNorm() > 0 ? 100.0 * (1.0 - (gap - contribution).squaredNorm() / gap.squaredNorm())
                            : 0.0;
  ev.figures = {{"odd_part_pct", odd_pct},         {"even_part_pct", even_pct},
                {"correlation_with_tilt", r_tilt}, {"correlation_with_time", r_time},
                {"explained_pct", explained},      {"per_test_pattern_match", r_fit}};
  AddToolAndHarmonicFigures(gap, ev.figures);
  const auto* effect = hexapod::FindHexapodEffect(c.effect);
  char buf[600];
  std::string why;
  if (c.effect == "gravity_deflection") {
    std::snprintf(buf, sizeof buf,
                  "the gap is mostly even (CW and CCW alike: even part %.0f %%, odd part %.0f %% "
                  "of its RMS) and its size per test follows |tilt| (r = %.2f)",
                  even_pct, odd_pct, r_tilt);
  } else if (c.effect == "joint_friction") {
    std::snprintf(buf, sizeof buf,
                  "the CW−CCW difference carries the gap (odd part %.0f %% of its RMS) and "
                  "reverses with the direction; it ramps after each reversal (%s)",
                  odd_pct, c.variant.c_str());
  } else if (c.effect == "thermal_drift") {
    std::snprintf(buf, sizeof buf,
                  "the gap grows with time across the tests (r = %.2f with the test time) and "
                  "is alike CW and CCW (even part %.0f %%)",
                  r_time, even_pct);
  } else if (c.effect == "tool_length_error") {
    std::snprintf(buf, sizeof buf,
                  "the gap is even (%.0f %%) and per test it follows the tool-axis shift the "
                  "model predicts for the tool used (r = %.2f)",
                  even_pct, r_fit);
  } else {
    std::snprintf(buf, sizeof buf, "even part %.0f %%, odd part %.0f %%; per-test match r = %.2f",
                  even_pct, odd_pct, r_fit);
  }
  why = buf;
  char tail[200];
  std::snprintf(tail, sizeof tail, "; the fitted %s explains %.0f %% of the gap's variance",
                c.effect.c_str(), explained);
  ev.sentence = std::string(effect ? effect->Signature() : "") + ": " + why + tail + ".";
  ev.sentence[0] = static_cast<char>(std::toupper(ev.sentence[0]));
  return ev;
}

}  // namespace km::discovery
