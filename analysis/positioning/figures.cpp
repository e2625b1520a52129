#include "analysis/positioning/figures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "analysis/core/errors.h"

namespace km::positioning {
namespace {

// Targets are matched to 1 nm: a target read in several runs carries the same coordinate.
long long TargetKey(double target_mm) {
  return std::llround(target_mm * 1e6);
}

std::string Mm(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g mm", v);
  return buf;
}

const char* Arrow(int direction) {
  return direction > 0 ? "+" : "-";
}

struct RunInfo {
  std::size_t count = 0;
  std::size_t first_line = 0;
};

struct TargetReadings {
  double target_mm = 0.0;
  std::size_t first_line = 0;
  std::map<long, double> up, down;  // run → deviation
};

struct Grouped {
  std::map<long, RunInfo> runs;
  std::map<long long, TargetReadings> targets;
};

Grouped Group(const std::vector<Reading>& readings, const std::string& file) {
  Grouped g;
  for (const Reading& r : readings) {
    RunInfo& run = g.runs[r.run];
    if (run.count++ == 0) run.first_line = r.line;
    auto [it, fresh] = g.targets.try_emplace(TargetKey(r.target_mm));
    TargetReadings& t = it->second;
    if (fresh) {
      t.target_mm = r.target_mm;
      t.first_line = r.line;
    }
    auto& side = r.direction > 0 ? t.up : t.down;
    if (!side.emplace(r.run, r.deviation_um).second) {
      throw InvalidInput(file, r.line, "target_mm",
                         "target " + Mm(r.target_mm) + " is read twice in the " +
                             Arrow(r.direction) + " direction of run " + std::to_string(r.run));
    }
  }
  return g;
}

void CheckBothDirections(const Grouped& g, const std::string& file) {
  for (const auto& [key, t] : g.targets) {
    if (t.up.empty() || t.down.empty()) {
      throw InvalidInput(file, t.first_line, "direction",
                         "target " + Mm(t.target_mm) + " is approached in the " +
                             (t.up.empty() ? "-" : "+") +
                             " direction only; every target needs both directions");
    }
  }
}

void CheckRunLengths(const Grouped& g, const std::string& file) {
  const auto& [first_run, first] = *g.runs.begin();
  for (const auto& [run, info] : g.runs) {
    if (info.count != first.count) {
      throw InvalidInput(file, info.first_line, "run",
                         "run " + std::to_string(run) + " has " + std::to_string(info.count) +
                             " readings, run " + std::to_string(first_run) + " has " +
                             std::to_string(first.count) + "; runs of unequal length");
    }
  }
}

void CheckEveryRun(const Grouped& g, const std::string& file) {
  for (const auto& [key, t] : g.targets) {
    for (const auto* side : {&t.up, &t.down}) {
      for (const auto& [run, info] : g.runs) {
        if (side->count(run)) continue;
        throw InvalidInput(file, info.first_line, "target_mm",
                           "target " + Mm(t.target_mm) + " (first read on line " +
                               std::to_string(t.first_line) + ") is not read in the " +
                               (side == &t.up ? "+" : "-") + " direction of run " +
                               std::to_string(run) + "; every target must repeat in every run");
      }
    }
  }
}

void MeanAndS(const std::map<long, double>& values, double& mean, double& s) {
  double sum = 0.0;
  for (const auto& [run, v] : values) sum += v;
  const double n = static_cast<double>(values.size());
  mean = sum / n;
  double ss = 0.0;
  for (const auto& [run, v] : values) ss += (v - mean) * (v - mean);
  s = std::sqrt(ss / (n - 1.0));
}

TargetFigures FiguresOf(const TargetReadings& t) {
  TargetFigures f;
  f.target_mm = t.target_mm;
  MeanAndS(t.up, f.mean_up_um, f.s_up_um);
  MeanAndS(t.down, f.mean_down_um, f.s_down_um);
  f.reversal_um = f.mean_up_um - f.mean_down_um;
  f.mean_bidirectional_um = 0.5 * (f.mean_up_um + f.mean_down_um);
  f.repeatability_um = std::max({2.0 * f.s_up_um + 2.0 * f.s_down_um + std::abs(f.reversal_um),
                                 4.0 * f.s_up_um, 4.0 * f.s_down_um});
  return f;
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void Add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  double Span() const { return hi - lo; }
};

void AddWarnings(PositioningFigures& out) {
  out.iso230_2_compliant = out.runs >= kIsoMinRuns && out.targets.size() >= kIsoMinTargets;
  if (out.runs < kIsoMinRuns) {
    out.warnings.push_back("only " + std::to_string(out.runs) +
                           " runs: ISO 230-2 needs at least 5 runs in each direction; the figures "
                           "are computed but the test is not compliant");
  }
  if (out.targets.size() < kIsoMinTargets) {
    out.warnings.push_back("only " + std::to_string(out.targets.size()) +
                           " targets: ISO 230-2 needs at least 5 targets; the figures are "
                           "computed but the test is not compliant");
  }
}

}  // namespace

Iso230Figures AxisFigures(const std::vector<TargetFigures>& targets) {
  Iso230Figures a;
  Range up, down, both, mean, acc_up, acc_down, acc;
  double reversal_sum = 0.0;
  for (const TargetFigures& t : targets) {
    a.reversal_value_um = std::max(a.reversal_value_um, std::abs(t.reversal_um));
    reversal_sum += t.reversal_um;
    a.repeatability_up_um = std::max(a.repeatability_up_um, 4.0 * t.s_up_um);
    a.repeatability_down_um = std::max(a.repeatability_down_um, 4.0 * t.s_down_um);
    a.repeatability_um = std::max(a.repeatability_um, t.repeatability_um);
    up.Add(t.mean_up_um);
    down.Add(t.mean_down_um);
    both.Add(t.mean_up_um);
    both.Add(t.mean_down_um);
    mean.Add(t.mean_bidirectional_um);
    acc_up.Add(t.mean_up_um + 2.0 * t.s_up_um);
    acc_up.Add(t.mean_up_um - 2.0 * t.s_up_um);
    acc_down.Add(t.mean_down_um + 2.0 * t.s_down_um);
    acc_down.Add(t.mean_down_um - 2.0 * t.s_down_um);
  }
  acc.lo = std::min(acc_up.lo, acc_down.lo);
  acc.hi = std::max(acc_up.hi, acc_down.hi);
  a.mean_reversal_value_um = targets.empty() ? 0.0 : reversal_sum / double(targets.size());
  a.systematic_deviation_up_um = up.Span();
  a.systematic_deviation_down_um = down.Span();
  a.systematic_deviation_um = both.Span();
  a.mean_deviation_range_um = mean.Span();
  a.accuracy_up_um = acc_up.Span();
  a.accuracy_down_um = acc_down.Span();
  a.accuracy_um = acc.Span();
  return a;
}

Vdi3441Figures VdiFigures(const std::vector<TargetFigures>& targets) {
  Vdi3441Figures v;
  Range mean, band;
  for (const TargetFigures& t : targets) {
    const double ps = 6.0 * 0.5 * (t.s_up_um + t.s_down_um);
    const double u = std::abs(t.mean_up_um - t.mean_down_um);
    v.position_scatter_per_target_um.push_back(ps);
    v.reversal_span_per_target_um.push_back(u);
    v.position_scatter_um = std::max(v.position_scatter_um, ps);
    v.reversal_span_um = std::max(v.reversal_span_um, u);
    mean.Add(t.mean_bidirectional_um);
    band.Add(t.mean_bidirectional_um + 0.5 * (u + ps));
    band.Add(t.mean_bidirectional_um - 0.5 * (u + ps));
  }
  v.position_deviation_um = mean.Span();
  v.position_uncertainty_um = band.Span();
  return v;
}

PositioningFigures EvaluatePositioning(const std::vector<Reading>& readings,
                                       const std::string& file) {
  if (readings.empty()) throw InvalidInput(file, 0, "run", "no readings");
  const Grouped g = Group(readings, file);
  CheckBothDirections(g, file);
  CheckRunLengths(g, file);
  CheckEveryRun(g, file);
  if (g.runs.size() < 2) {
    throw InvalidInput(file, g.runs.begin()->second.first_line, "run",
                       "one run only; the standard uncertainties need at least 2 runs");
  }
  PositioningFigures out;
  out.runs = g.runs.size();
  out.readings = readings.size();
  out.targets.reserve(g.targets.size());
  for (const auto& [key, t] : g.targets) out.targets.push_back(FiguresOf(t));
  out.iso = AxisFigures(out.targets);
  out.vdi = VdiFigures(out.targets);
  AddWarnings(out);
  return out;
}

}  // namespace km::positioning
