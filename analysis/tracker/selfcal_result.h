// The options and the result of a laser-tracker self-calibration (analysis/tracker/
// tracker_selfcal.h, which solves it): its own header, so the stages of the solve
// (tracker_selfcal_stages.h) and the propagation of the readings' uncertainty use these types
// without including the solve they are parts of.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/tracker/selfcal_problem.h"
#include "analysis/tracker/selfcal_solver.h"
#include "analysis/tracker/tracker_types.h"
#include "analysis/tracker/volumetric_decomposition.h"

namespace km::tracker {

struct SelfCalOptions {
  bool reject_outliers = true;
  double outlier_k = 6.0;          // rejection threshold in robust σ
  double outlier_floor_um = 0.05;  // the threshold is never below this
  int max_rejection_rounds = 8;
  double robust_scale_um = 1.0;  // Cauchy scale of the first pass; 0 = none
  int max_iterations = 100;
  double max_condition_number = 1e8;  // of the reduced Jacobian; larger = NotObservable
  double prior_sigma_um = 0.2;        // reading σ used when there is no redundancy
  // Warning (never a rejection) for points whose volumetric error, after a quadratic trend,
  // departs from the median of its 6 nearest neighbours by more than outlier_k times the map's
  // robust local scatter and the point's own precision (SelfCalResult::spatial_outliers).
  bool spatial_check = true;

  // Throws km::InvalidInput naming the bad option.
  void Check() const;
};

struct RejectedReading {
  int row = 0;                   // 0-based row (point index in the file)
  int point_id = 0;              // as in the file
  int tracker = 0;               // 0-based
  double residual_um = 0.0;      // residual of eq. (1) when rejected
  double standardised_um = 0.0;  // residual / √(1 − leverage): comparable between readings
  std::string reason;            // "residual" (the only reason a reading is rejected)
};

// A point named by the spatial check (a warning: the point is kept with all its readings).
struct SpatialOutlier {
  int row = 0;       // 0-based row (point index in the file)
  int point_id = 0;  // as in the file
  // Volumetric error (quadratic trend removed) minus the median of its nearest neighbours'.
  Eigen::Vector3d departure_um = Eigen::Vector3d::Zero();
  double departure_sigmas = 0.0;         // largest component in sqrt(scatter² + own σ²)
  double largest_standardised_um = 0.0;  // of its readings: what the readings say
  std::string reason;
};

struct SelfCalResult {
  TrackerMode mode = TrackerMode::kSimultaneous;
  std::vector<Eigen::Vector3d> trackers_mm;             // gauge frame
  std::vector<Eigen::Vector3d> tracker_uncertainty_um;  // 1σ per axis, gauge frame
  // Per interferometer segment (a tracker's readings from row 0 or from a beam break on): the
  // tracker's distance to its zero, |u_z − U_j| when zeroed at point z (derived), the estimated
  // dead path when zeroed elsewhere.
  std::vector<double> dead_path_mm;
  std::vector<int> dead_path_tracker;      // 0-based tracker of each segment
  std::vector<int> dead_path_from_row;     // 0-based first row of each segment
  std::vector<int> dead_path_zero_row;     // 0-based row of its zero point; −1: zeroed elsewhere
  std::vector<Eigen::Vector3d> points_mm;  // gauge frame (NaN when dropped)
  std::vector<char> point_valid;           // 0 = all readings rejected
  std::vector<Eigen::Vector3d> volumetric_error_um;  // commanded frame (NaN when dropped)
  // 1σ per axis of the volumetric error (commanded frame, rigid motion removed: gauge-free).
  std::vector<Eigen::Vector3d> position_uncertainty_um;
  // 1σ per axis of points_mm in the gauge frame (includes the uncertainty of the gauge itself).
  std::vector<Eigen::Vector3d> gauge_uncertainty_um;
  // Full covariance of the volumetric errors (commanded frame, low-rank form) for
  // DecomposeVolumetricError, which then propagates the tracker-induced correlations.
  VolumetricCovariance error_covariance;
  RigidTransform gauge_to_commanded;
  double residual_rms_um = 0.0;
  double sigma_um = 0.0;  // a-posteriori reading σ
  double condition_number = 0.0;
  std::vector<RejectedReading> rejected;
  std::vector<SpatialOutlier> spatial_outliers;  // warnings only: these points are kept
  std::size_t readings_used = 0;
  std::size_t unknowns = 0;
  int rounds = 0;
  int iterations = 0;
  std::vector<double> initial_rms_um;  // per tracker, fit of the initialisation
  std::vector<std::string> warnings;   // solvable but weak or ambiguous set-ups
};

// The solved problem behind a result: the readings in use (rejected ones inactive), the
// least-squares optimum in the gauge frame and the options of its last solve. What a propagation
// of the readings' uncertainty re-solves from (selfcal_uncertainty.h).
struct SelfCalSolution {
  SelfCalProblem problem;
  SelfCalState state;
  SolveOptions solve;
};

}  // namespace km::tracker
