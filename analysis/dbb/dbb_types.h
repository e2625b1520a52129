// Domain record of a DBB (double ball bar) circular test, as ingest/ delivers it to the
// analysis (docs/formats.md §1.1). Positions in mm, bar deviations in µm, angles in degrees as
// written in the file (converted to radians inside the analysis).
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace km::dbb {

enum class Direction { kCcw, kCw };
enum class Plane { kXY, kYZ, kZX };

const char* ToString(Direction d);
const char* ToString(Plane p);

struct DbbTest {
  std::string machine_id;
  std::string test_id;
  Direction direction = Direction::kCcw;
  Plane plane = Plane::kXY;
  double bar_length_mm = 0.0;  // R_DBB
  double radius_mm = 0.0;      // R (commanded radius of the moving-ball circle)
  std::array<double, 3> centre_mm{};
  double z_offset_mm = 0.0;  // moving-ball plane minus fixed-ball height
  double feed_mm_min = 0.0;
  std::array<double, 3> tilt_deg{};
  std::optional<double> tool_length_mm;
  std::optional<std::array<double, 3>> fixed_ball_mm;  // present => absolute evaluation
  std::optional<std::string> timestamp;
  std::optional<double> temperature_c;
  // Length of the arc the test runs (degrees): 360 for a full turn, less for a partial arc
  // (coverage.h). Absent: inferred from the samples.
  std::optional<double> arc_deg;
  std::map<std::string, std::string> metadata;  // every header key, known or not

  // Samples in time order. angle_deg is the commanded angle of the moving ball about the
  // centre, in the plane (decreasing for cw); dr_um is bar length minus bar_length_mm.
  std::vector<double> angle_deg;
  std::vector<double> dr_um;
};

}  // namespace km::dbb
