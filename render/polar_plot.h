// Polar plot of DBB traces (PNG), drawn with OpenCV and encoded in memory (no file I/O).
//
// A radial deviation d (µm, about a reference centre — the least-squares centre) at angle θ is
// drawn at the radius  r_px = r0_px + k·d  (magnified: k px/µm chosen so that the largest
// deviation fills a fixed band around the reference circle r0_px). Rings mark d = 0 (the
// least-squares circle) and ± whole divisions; the scale is printed in µm/div. A minimum-zone
// pair of circles with centre δ (µm, relative to the reference centre) and radii ρ_in, ρ_out
// (as deviations) is drawn as d(θ) = ρ + δ·(cos θ, sin θ), its first-order image under the
// magnification. Angles run counter-clockwise from the first plane axis (to the right).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace km::render {

struct PolarPlotTrace {
  std::string label;  // e.g. "ccw", "cw"
  std::vector<double> angle_rad;
  std::vector<double> dev_um;  // about the reference (least-squares) centre
  std::array<unsigned char, 3> bgr{200, 60, 20};
};

struct PolarPlotZone {
  std::array<double, 2> centre_um{0.0, 0.0};  // relative to the reference centre
  double inner_um = 0.0;                      // as deviations about the reference circle
  double outer_um = 0.0;
};

struct PolarPlotOptions {
  int size_px = 800;
  std::string title;
  std::string first_axis = "X";
  std::string second_axis = "Y";
  double um_per_div = 0.0;  // 0: chosen automatically (1-2-5 steps)
  // Divisions of the ± band (0: as many as the largest deviation needs). With um_per_div also
  // given the magnification is fixed, so plots of different tests share one scale.
  int divisions = 0;
  std::vector<std::string> notes;  // lines of key figures printed at the lower left
};

// The scale of a plot: µm a division and the divisions of the ± band (options.um_per_div and
// options.divisions where given, else the 1-2-5 step that fits the largest deviation). Throws
// km::InvalidInput for an empty plot, traces of unequal lengths or a bad scale option.
struct PolarScale {
  double um_per_div = 1.0;
  int divisions = 1;
};
PolarScale ChoosePolarScale(const std::vector<PolarPlotTrace>& traces,
                            const std::optional<PolarPlotZone>& min_zone,
                            const PolarPlotOptions& options);

// Returns the PNG bytes. Throws km::InvalidInput on an empty plot or size below 200 px.
std::vector<unsigned char> RenderPolarPlot(const std::vector<PolarPlotTrace>& traces,
                                           const std::optional<PolarPlotZone>& min_zone,
                                           const PolarPlotOptions& options = {});

}  // namespace km::render
