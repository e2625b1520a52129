// The polar plot of a DBB test of an analysed set (analysis/dbb/full_analysis.h), with its pair
// partner if it has one: the deviations about the test's least-squares centre, its minimum-zone
// circles, its key figures in the lower left (render/polar_plot.h draws it).
#pragma once

#include <cstddef>
#include <vector>

#include "analysis/dbb/full_analysis.h"
#include "render/polar_plot.h"

namespace km::render {

// PNG bytes. Throws km::InvalidInput when test_index is not a test of the report.
std::vector<unsigned char> DbbPolarPlotPng(const dbb::DbbReport& report, std::size_t test_index,
                                           const PolarPlotOptions& options = {});

}  // namespace km::render
