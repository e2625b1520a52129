// Records of a laser-tracker multilateration survey ([Tracker paper], docs/formats.md §1.2).
//
// Tracker j (station j in sequential mode) sits at U_j; the target (a corner cube on the
// spindle) is commanded to c_i and really stands at u_i. Each tracker's interferometer is zeroed
// at the first point and reads the displacement relative to it ([Tracker paper] eq. 1):
//
//   d_ij = |u_i − U_j| − |u_1 − U_j|.
//
// A beam break re-zeroes the interferometer. Re-zeroed at a surveyed point k (the point the
// break names), its readings from k on are eq. (1) with u_k in place of u_1; re-zeroed at a
// place that is not a surveyed point (BeamBreak::elsewhere), they are relative to an unknown
// length: a free dead path.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace km::tracker {

enum class TrackerMode { kSimultaneous, kSequential };

const char* ModeName(TrackerMode mode);

// From row `row` on (0-based, inclusive), tracker `tracker` (0-based) reads relative to a new
// zero: the point of row `row` itself (its reading there is 0), or, when `elsewhere`, a place
// that is not a surveyed point (an unknown dead path).
struct BeamBreak {
  int tracker = 0;
  std::size_t row = 0;
  bool elsewhere = false;
};

// Rough tracker (station) position in the machine frame of the commanded points. A guess
// farther than kMaxTrackerGuessMm from the origin in any coordinate (or not finite) is refused:
// no laser-tracker survey of a machine tool spans 100 m.
inline constexpr double kMaxTrackerGuessMm = 1e5;
struct TrackerGuess {
  int tracker = 0;  // 0-based
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
};

struct TrackerReadings {
  std::string machine_id;
  TrackerMode mode = TrackerMode::kSimultaneous;
  std::vector<int> point_ids;                 // m, as in the file
  std::vector<Eigen::Vector3d> commanded_mm;  // m, machine frame
  Eigen::MatrixXd displacement_um;            // m × n, d_ij; a non-finite value = missing
  std::vector<BeamBreak> beam_breaks;
  std::vector<TrackerGuess> guesses;

  int NumPoints() const { return static_cast<int>(commanded_mm.size()); }
  int NumTrackers() const { return static_cast<int>(displacement_um.cols()); }
};

}  // namespace km::tracker
