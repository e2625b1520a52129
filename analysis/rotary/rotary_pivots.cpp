#include "analysis/rotary/rotary_pivots.h"

#include <utility>

namespace km::rotary {
namespace {

PivotParameter Param(std::string name, double nominal_mm, bool known, double delta_um) {
  PivotParameter p{std::move(name), nominal_mm, std::nullopt, std::nullopt};
  if (known) {
    p.delta_mm = 1e-3 * delta_um;
    p.corrected_mm = nominal_mm + *p.delta_mm;
  }
  return p;
}

}  // namespace

PivotCorrection LinuxCncPivots(const RotarySetup& setup, const LocationErrors& e,
                               const std::array<bool, kLocationErrorCount>& d) {
  const bool ac = setup.kinematics == Kinematics::kAcTrunnion;
  PivotCorrection out;
  out.kinematics = setup.kinematics;
  out.module = ac ? "xyzac-trt-kins" : "xyzbc-trt-kins";
  const auto& c = setup.c_axis_mm;
  const auto& t = setup.tilt_axis_mm;  // AC (y, z) of the A line; BC (x, z) of the B line
  // Index 0: the tilt line's position across its axis (AC: Y, BC: X); 1: its Z; 4, 5: XOC, YOC.
  out.params[0] = Param("x-rot-point", c[0], d[4], e[4]);
  out.params[1] = Param("y-rot-point", c[1], d[5], e[5]);
  out.params[2] = Param("z-rot-point", 0.0, true, 0.0);
  if (ac) {  // y-offset: the A line's Y relative to the C line's
    out.params[3] = Param("y-offset", t[0] - c[1], d[0] && d[5], e[0] - e[5]);
  } else {  // x-offset: the B line's X relative to the C line's
    out.params[3] = Param("x-offset", t[0] - c[0], d[0] && d[4], e[0] - e[4]);
  }
  out.params[4] = Param("z-offset", t[1], d[1], e[1]);
  out.mechanical = {2, 3, 6, 7};
  out.corrected_setup = setup;
  for (int k = 0; k < 2; ++k) {
    if (d[std::size_t(4 + k)])
      out.corrected_setup.c_axis_mm[std::size_t(k)] += 1e-3 * e[std::size_t(4 + k)];
    if (d[std::size_t(k)])
      out.corrected_setup.tilt_axis_mm[std::size_t(k)] += 1e-3 * e[std::size_t(k)];
  }
  return out;
}

}  // namespace km::rotary
