// The records of an R-test of the rotary axes of a five-axis machine with a trunnion table
// (docs/formats.md §1.10, docs/methods.md §17): the nominal axis lines, the sphere, the poses and
// the sphere's measured displacement at each. Plain data, no I/O: ingest/rotary/rotary_parser
// fills them, analysis/rotary/ evaluates them.
//
// The eight location errors of ISO 230-1 ([ISO 230-1]), in the order of LocationErrors:
//   AC-trunnion (A about X carries C): YOA, ZOA (µm), BOA, COA (µrad); XOC, YOC (µm), AOC, BOC
//   (µrad) BC-trunnion (B about Y carries C): XOB, ZOB (µm), AOB, COB (µrad); XOC, YOC (µm), AOC,
//   BOC (µrad)
// Their geometric definitions are in analysis/rotary/rotary_model.h.
#pragma once

#include <array>
#include <cstddef>
#include <string_view>
#include <vector>

namespace km::rotary {

enum class Kinematics { kAcTrunnion, kBcTrunnion };

inline constexpr std::size_t kLocationErrorCount = 8;

// µm (indices 0, 1, 4, 5) and µrad (indices 2, 3, 6, 7).
using LocationErrors = std::array<double, kLocationErrorCount>;

struct RotarySetup {
  Kinematics kinematics = Kinematics::kAcTrunnion;
  // The nominal tilt-axis line: AC (y, z) where the A line (parallel to X) crosses X = 0;
  // BC (x, z) where the B line (parallel to Y) crosses Y = 0. mm, machine coordinates.
  std::array<double, 2> tilt_axis_mm{{0.0, 0.0}};
  // The nominal C line at zero tilt: (x, y) where it (parallel to Z) crosses Z = 0. mm.
  std::array<double, 2> c_axis_mm{{0.0, 0.0}};
  // The sphere's centre at zero angles, machine coordinates, mm.
  std::array<double, 3> sphere_mm{{0.0, 0.0, 0.0}};
};

// One pose: the tilt angle (A or B) and the C angle as the table turns (a positive angle turns
// the table right-handed about +X, +Y or +Z), and the sphere centre's displacement from the
// nest held at its nominal position, machine coordinates.
struct RotaryPose {
  double tilt_deg = 0.0;
  double c_deg = 0.0;
  std::array<double, 3> d_um{{0.0, 0.0, 0.0}};
};

struct RotaryTest {
  RotarySetup setup;
  std::vector<RotaryPose> poses;  // the first at zero angles
};

// "AC-trunnion" or "BC-trunnion".
std::string_view KinematicsName(Kinematics k);
// The tilt axis letter, 'A' or 'B'.
char TiltLetter(Kinematics k);
// The names of the eight location errors in LocationErrors order ("YOA", …, "BOC").
const std::array<std::string_view, kLocationErrorCount>& LocationErrorNames(Kinematics k);
// True for the direction errors (µrad), false for the position errors (µm).
constexpr bool IsAngularError(std::size_t index) {
  return (index % 4) >= 2;
}

}  // namespace km::rotary
