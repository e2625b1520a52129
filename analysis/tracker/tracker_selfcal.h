// Laser-tracker multilateration self-calibration ([Tracker paper] §4, methods §8).
//
// Given each tracker's displacement readings d_ij relative to point 1 ([Tracker paper] eq. 1) and
// the commanded target positions c_i, estimate the tracker positions U_j and the true target
// positions u_i by least squares on
//
//   r_ij = |u_i − U_j| − |u_z − U_j| − d_ij        ([Tracker paper] eqs. 1–4; selfcal_problem.h)
//
// z the point the tracker's interferometer was zeroed at: point 1, or the point of a beam break
// after which it was re-zeroed there. The zero is exact — the reading at z is 0 by definition,
// not an observation, and no dead path is estimated; only a tracker re-zeroed at a place that is
// not a surveyed point (a beam break marked `elsewhere`, docs/formats.md §1.2) reads relative to
// an unknown dead path L_s, estimated with the rest. The gauge is that of docs/formats.md §3
// (U_1 = 0, U_2 on +x, U_3 in the xy-plane with y > 0, z of U_4 > 0). `simultaneous` (n trackers
// at once) and `sequential` (one tracker at n stations, the same points repeated per station,
// each station zeroed at point 1) have the same unknowns. The solve: per-tracker initialisation
// (selfcal_problem.h), a least-squares pass (selfcal_solver.h), a short robust (Cauchy) pass that
// exposes gross errors (only readings beyond 3× the threshold are taken out from it), then rounds
// of rejection (|z| > k·σ_robust on residuals standardised by their leverage, σ_robust =
// 1.4826·median|z|) with least-squares re-solves until the last one has converged: on clean data
// the result is the least-squares optimum of eq. (1) over all readings. A point seen by only 4
// trackers has one redundant reading, so a gross error cannot be pinned on one tracker: all its
// readings are rejected (the point is dropped); with ≥ 5 readings only the worst reading is
// rejected per round.
//
// Readings are rejected only on the evidence of the readings themselves (their residuals and
// leverage: the other trackers' view of the same point), never because the machine's error
// field is not smooth — periodic errors of ball screws and guides are what a survey is for. The
// spatial check (SelfCalOptions::spatial_check) only WARNS: it names the points whose volumetric
// error stands far out from their neighbours' (SelfCalResult::spatial_outliers, one line in
// warnings) and keeps them. Two gross errors on a 4-tracker point can cancel in its single
// redundant reading; the readings cannot show them, this warning can.
//
// The volumetric error of point i is R·u_i + t − c_i after the best-fit rigid transform
// (R, t) of the estimated points to the commanded frame; R may be a mirror when the gauge frame
// is the mirror image of the machine frame (distances cannot tell them apart). Its uncertainty
// comes from the Schur-reduced JᵀJ with the rigid motion of the point set projected out.
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

// Throws km::NotObservable (counting condition, rank deficiency, condition number) or
// km::InvalidInput (inconsistent readings) or km::DidNotConverge. `solution` (optional) receives
// the solved problem.
SelfCalResult SelfCalibrate(const TrackerReadings& readings, const SelfCalOptions& options = {},
                            SelfCalSolution* solution = nullptr);

}  // namespace km::tracker
