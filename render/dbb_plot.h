// The polar plot of a DBB test of an analysed set (analysis/dbb/full_analysis.h), with its pair
// partner if it has one: the deviations about the test's least-squares centre, its minimum-zone
// circles, its key figures in the lower left (render/polar_plot.h draws it).
#pragma once

#include <cstddef>
#include <vector>

#include "analysis/dbb/full_analysis.h"
#include "render/polar_plot.h"

namespace km::render {

// What the polar plot of a test draws: its trace (and its partner's), about the test's
// least-squares centre, its minimum-zone circles, title, axes and key figures. Throws
// km::InvalidInput when test_index is not a test of the report.
struct DbbPolar {
  std::vector<PolarPlotTrace> traces;
  PolarPlotZone zone;
  PolarPlotOptions options;
};
DbbPolar DbbPolarPlot(const dbb::DbbReport& report, std::size_t test_index,
                      const PolarPlotOptions& options = {});

// The scale the dashboard draws the plot of a test at (web/static/polar.js chooseScale): µm a
// division the 1-2-5 step of the largest |radial error| (about each trace's own least-squares
// circle) of the test and its pair partner divided by 2.6, and 3 divisions each side.
PolarScale DbbPageScale(const dbb::DbbReport& report, std::size_t test_index);

// PNG bytes of DbbPolarPlot.
std::vector<unsigned char> DbbPolarPlotPng(const dbb::DbbReport& report, std::size_t test_index,
                                           const PolarPlotOptions& options = {});

}  // namespace km::render
