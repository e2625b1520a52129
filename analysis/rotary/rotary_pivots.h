// Compensation of the location errors in the pivot parameters of LinuxCNC's table-rotary-tilting
// kinematics, xyzac-trt-kins and xyzbc-trt-kins (docs/methods.md §17.7, [LinuxCNC trt kins]).
// Those modules turn the table about a C line parallel to Z through (x-rot-point, y-rot-point)
// and about a tilt line parallel to X (AC: through y = y-rot-point + y-offset,
// z = z-rot-point + z-offset) or to Y (BC: through x = x-rot-point + x-offset,
// z = z-rot-point + z-offset). Moving those lines onto the actual ones corrects the four
// position errors; the four direction errors (AC: BOA, COA, AOC, BOC; BC: AOB, COB, AOC, BOC)
// cannot be expressed by lines parallel to the axes: they are to be adjusted mechanically.
//
// The file's nominal lines are taken as the controller's present values (the same machine
// coordinates, z-rot-point = 0 at the file's Z origin, where the C position errors are defined).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "analysis/rotary/rotary_types.h"

namespace km::rotary {

struct PivotParameter {
  std::string name;                // the HAL pin's name after the module prefix: "x-rot-point"
  double nominal_mm = 0.0;         // from the file's nominal lines
  std::optional<double> delta_mm;  // the correction; none when its errors are not determined
  std::optional<double> corrected_mm;
};

struct PivotCorrection {
  Kinematics kinematics = Kinematics::kAcTrunnion;
  std::string module;                    // "xyzac-trt-kins" or "xyzbc-trt-kins"
  std::array<PivotParameter, 5> params;  // x-rot-point, y-rot-point, z-rot-point, offsets
  std::vector<std::size_t> mechanical;   // the direction errors: adjust mechanically
  RotarySetup corrected_setup;           // the nominal lines moved by the corrections
};

// `errors`: the identified location errors (µm, µrad); `determined`: which have a value.
PivotCorrection LinuxCncPivots(const RotarySetup& setup, const LocationErrors& errors,
                               const std::array<bool, kLocationErrorCount>& determined);

}  // namespace km::rotary
