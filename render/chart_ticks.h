// The ticks of a report chart's axis (render/pdf_report_plots.cpp draws them): "nice" steps of
// 1, 2 or 5 × 10^k, and whole-number ticks on an axis of whole numbers (a study's step number),
// never a tick between two steps.
#pragma once

#include <string>
#include <vector>

namespace km::render {

// About `count` ticks covering [lo, hi], each a multiple of a step of 1, 2 or 5 × 10^k; with
// `whole_numbers` the step is at least 1, so every tick is a whole number. {lo} when the range is
// empty or not finite.
std::vector<double> AxisTicks(double lo, double hi, int count, bool whole_numbers = false);

// A tick's label with the decimals its step needs ("0.5", "2", "0.02"), no "-0".
std::string TickLabel(double v, double step);

}  // namespace km::render
