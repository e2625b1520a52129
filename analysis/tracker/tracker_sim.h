// Synthetic laser-tracker surveys for tests, demos and benchmarks ([Tracker paper] set-up: a target
// on the spindle of a 3-axis machine, trackers around the work volume).
//
// The machine places the target at u_i = c_i + e(c_i) with the geometric error model of
// volumetric_decomposition.h eq. (1) (scales, squareness, polynomial positioning/straightness)
// plus periodic terms (ball-screw or guide waviness), which no low-order polynomial describes.
// Tracker j reads d_ij = |u_i − U_j| + n_ij − |u_r − U_j|, r the first row of the reading's
// segment (row 0, or the row of the last beam break), n ~ N(0, σ²), and exactly 0 at r: the zero
// is exact ([Tracker paper] eq. 1) — the interferometer's counter is reset where the target
// stands, and u_r is that place. In sequential mode the target scatters by the machine's
// repeatability at every visit, the zero's visit of each station included (the one part of the
// noise common to a station's readings). A break re-zeroed elsewhere (BeamBreak::elsewhere)
// reads relative to a place 20–100 mm nearer or farther along the beam than its point.
#pragma once

#include <array>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "analysis/tracker/tracker_types.h"

namespace km::tracker {

// A periodic error of one axis: component `direction` gains A·sin(2π·c_axis/period + phase),
// c_axis the commanded coordinate of `axis` (machine frame). axis = direction: positioning
// (e.g. a ball-screw pitch error), otherwise straightness (guide waviness).
struct PeriodicError {
  int axis = 0;       // 0, 1, 2 = x, y, z
  int direction = 1;  // component of the error it enters
  double amplitude_um = 0.0;
  double period_mm = 100.0;
  double phase_rad = 0.0;
};

struct MachineErrorModel {
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_range_mm = Eigen::Vector3d::Ones();  // normalises the polynomials
  Eigen::Vector3d scale_ppm = Eigen::Vector3d::Zero();
  // xy, yz, zx in µm/m; applied as a tilt of the second axis towards −first (e_x −= S_xy·y,
  // e_y −= S_yz·z, e_z −= S_zx·x).
  Eigen::Vector3d squareness_um_per_m = Eigen::Vector3d::Zero();
  // poly_um[a][dir][k]: coefficient (µm) of the Legendre polynomial P_k(t_a), k = 2, 3, in
  // component dir (as in volumetric_decomposition.h eq. 1).
  std::array<std::array<std::array<double, 4>, 3>, 3> poly_um{};
  std::vector<PeriodicError> periodic;

  Eigen::Vector3d ErrorUm(const Eigen::Vector3d& commanded_mm) const;
};

struct TrackerSimOptions {
  std::vector<Eigen::Vector3d> trackers_mm;   // true positions, machine frame
  std::vector<Eigen::Vector3d> commanded_mm;  // commanded target positions
  MachineErrorModel machine;
  TrackerMode mode = TrackerMode::kSimultaneous;
  double noise_um = 0.2;          // per reading
  double repeatability_um = 0.0;  // sequential: target scatter per station and point
  double outlier_fraction = 0.0;  // share of readings given a gross error
  double outlier_um = 50.0;       // ± size of a gross error
  std::vector<BeamBreak> beam_breaks;
  unsigned seed = 1;
};

struct TrackerSimResult {
  TrackerReadings readings;
  std::vector<Eigen::Vector3d> true_points_mm;  // u_i (machine frame)
  std::vector<std::pair<int, int>> outliers;    // (row, tracker) given a gross error
};

TrackerSimResult SimulateTrackerSurvey(const TrackerSimOptions& options);

// per_axis³ commanded points on a cube of edge size_mm centred at centre_mm (x fastest).
std::vector<Eigen::Vector3d> GridPoints(const Eigen::Vector3d& centre_mm, double size_mm,
                                        int per_axis);

// n trackers around centre_mm at distances in [min_mm, max_mm], spread in azimuth, at
// elevations alternating between −45°…−20° and −5°…+15°, tracker 4 off the plane of 1–3.
std::vector<Eigen::Vector3d> PlaceTrackers(const Eigen::Vector3d& centre_mm, int n, double min_mm,
                                           double max_mm, unsigned seed);

}  // namespace km::tracker
