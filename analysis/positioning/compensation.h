// Compensation table of a measured axis (docs/methods.md §15.5).
//
// The table holds, at each target P_i, the trim that cancels the mean unidirectional deviation:
// forward_i = −x̄_i↑ (applied while the axis moves towards larger coordinates), reverse_i = −x̄_i↓.
// A machine that overshoots by +10 µm at a target gets −10 µm there. Between targets the table is
// linear: controllers that need an even grid get the table resampled by linear interpolation
// (ResampleEvenGrid); outside the measured span the end values hold.
#pragma once

#include <cstddef>
#include <vector>

#include "analysis/positioning/figures.h"

namespace km::positioning {

struct CompensationTable {
  std::vector<double> target_mm;   // ascending
  std::vector<double> forward_um;  // −x̄↑
  std::vector<double> reverse_um;  // −x̄↓
};

CompensationTable MakeCompensation(const std::vector<TargetFigures>& targets);

// The even grid of a table: start at its first target, `count` points `step_mm` apart, ending at
// its last target. When the targets are already evenly spaced (to 1 µm) the grid is the targets.
struct EvenGrid {
  double start_mm = 0.0;
  double step_mm = 0.0;
  std::size_t count = 0;
  bool was_even = true;  // the targets were evenly spaced; no value is interpolated
};

EvenGrid EvenGridOf(const std::vector<double>& target_mm);

// Piecewise-linear value of (x, y) at `at` (x ascending, ≥ 1 point; constant beyond the ends).
double Interpolate(const std::vector<double>& x, const std::vector<double>& y, double at);

// The table at the points of `grid`.
CompensationTable ResampleEvenGrid(const CompensationTable& table, const EvenGrid& grid);

}  // namespace km::positioning
