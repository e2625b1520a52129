#include "analysis/positioning/compensation.h"

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"

namespace km::positioning {

CompensationTable MakeCompensation(const std::vector<TargetFigures>& targets) {
  CompensationTable t;
  for (const TargetFigures& f : targets) {
    t.target_mm.push_back(f.target_mm);
    t.forward_um.push_back(-f.mean_up_um);
    t.reverse_um.push_back(-f.mean_down_um);
  }
  return t;
}

EvenGrid EvenGridOf(const std::vector<double>& target_mm) {
  if (target_mm.size() < 2) throw InvalidInput("a compensation table needs at least 2 targets");
  EvenGrid g;
  g.start_mm = target_mm.front();
  g.count = target_mm.size();
  g.step_mm = (target_mm.back() - target_mm.front()) / double(g.count - 1);
  if (!(g.step_mm > 0.0)) throw InvalidInput("the targets of a compensation table must increase");
  for (std::size_t i = 0; i < target_mm.size(); ++i) {
    if (std::abs(target_mm[i] - (g.start_mm + g.step_mm * double(i))) > 1e-3) g.was_even = false;
  }
  return g;
}

double Interpolate(const std::vector<double>& x, const std::vector<double>& y, double at) {
  if (at <= x.front()) return y.front();
  if (at >= x.back()) return y.back();
  const auto hi = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), at) - x.begin());
  const std::size_t lo = hi - 1;
  const double w = (at - x[lo]) / (x[hi] - x[lo]);
  return y[lo] + w * (y[hi] - y[lo]);
}

CompensationTable ResampleEvenGrid(const CompensationTable& table, const EvenGrid& grid) {
  CompensationTable out;
  for (std::size_t i = 0; i < grid.count; ++i) {
    const double p = i + 1 == grid.count && grid.count > 1
                         ? table.target_mm.back()
                         : grid.start_mm + grid.step_mm * double(i);
    out.target_mm.push_back(p);
    out.forward_um.push_back(Interpolate(table.target_mm, table.forward_um, p));
    out.reverse_um.push_back(Interpolate(table.target_mm, table.reverse_um, p));
  }
  return out;
}

}  // namespace km::positioning
