// Problem description of the multilateration self-calibration ([Tracker paper] §4), separate from
// the solve (selfcal_solver.h).
//
// Each tracker's interferometer is zeroed at a surveyed point z (point 1, or the point of a beam
// break) and reads, at point i, d_ij = |u_i − U_j| − |u_z − U_j| ([Tracker paper] eq. 1). The
// zero is exact by definition: the reading at z is no observation (it is 0), and the length
// |u_z − U_j| is no unknown of its own. Unknowns: target positions u_i (3m, the zero points
// among them) and tracker positions U_j (3n); only a tracker re-zeroed at a place that is not a
// surveyed point (a beam break marked `elsewhere`) adds an unknown dead path L_s. Each reading
// gives the residual
//
//   r_ij = |u_i − U_j| − Z_s − d_ij,   Z_s = |u_z − U_j| (zeroed at point z) or L_s   (1)
//
// whose least-squares solution is that of [Tracker paper] eq. 2. The seven-parameter gauge of
// distances (rigid motion and mirror image) is fixed as in [Tracker paper] and docs/formats.md §3:
// U_1 = 0, U_2 on +x (V_2 = W_2 = 0), U_3 in the xy-plane with V_3 > 0, and W_4 > 0. Counting:
// with m points, n trackers, z re-zeroings at a point and f at other places, the readings must
// satisfy
//
//   n·(m − 1) − z ≥ 3m + 3n − 6 + f                                               (2)
//
// ([Tracker paper] lists p = [U2 U3 V3 U4 V4 W4 u1ᵀ … umᵀ] for n = 4). n = 3 never satisfies (2);
// n = 4 needs m ≥ 10 points. The count is necessary, not sufficient: all trackers in one plane
// ([Tracker paper]'s set-up, four trackers on the table) leave one direction of the tracker
// parameters free, and nearly coplanar trackers make the solution very uncertain; so do
// collinear points. The solver checks the rank and condition of the Schur-reduced normal matrix
// (ComputeCovariance).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "analysis/tracker/tracker_types.h"

namespace km::tracker {

// One reading as it enters eq. (1). Displacements in mm inside the solver.
struct Observation {
  int point = 0;
  int tracker = 0;
  int segment = 0;  // index into SelfCalProblem::segments
  double d_mm = 0.0;
};

// A tracker's readings from one zero on: from row 0, or from a beam break.
struct Segment {
  int tracker = 0;     // 0-based
  int start_row = 0;   // its first row
  int zero_point = 0;  // row of the surveyed point it was zeroed at; −1: elsewhere (dead path)
  bool FreeDeadPath() const { return zero_point < 0; }
};

// Current values of all unknowns (gauge frame once the gauge is applied).
struct SelfCalState {
  std::vector<Eigen::Vector3d> trackers_mm;
  std::vector<Eigen::Vector3d> points_mm;
  // Per segment, the tracker's distance to its zero Z_s: |u_z − U_j| for a segment zeroed at a
  // point (SelfCalProblem::UpdateZeroLengths keeps it), the dead path L_s (an unknown) otherwise.
  std::vector<double> offsets_mm;
};

// The fixed description: observations, segments, which readings are active.
struct SelfCalProblem {
  int num_points = 0;
  int num_trackers = 0;
  std::vector<Observation> observations;
  std::vector<Segment> segments;
  std::vector<char> active;  // per observation (rejected readings = 0)
  // What the readings made of a zero whose reading is not 0 (warnings): within 10 µm of 0 not
  // used, farther taken as a zero elsewhere (a dead path).
  std::vector<std::string> notes;

  // Builds the observation list from the readings: missing (non-finite) readings and the zero
  // readings (a segment's reading at its zero point) are no observations. Throws InvalidInput
  // for a beam break naming a tracker or row that does not exist.
  static SelfCalProblem FromReadings(const TrackerReadings& readings);

  int NumSegments() const { return static_cast<int>(segments.size()); }
  // Segments with at least one active reading.
  std::vector<char> SegmentsInUse() const;
  // Points that still have an active reading, or are the zero of a segment in use.
  std::vector<char> PointsInUse() const;
  std::size_t NumActive() const;
  // Unknowns of eq. (2) for the points and segments in use.
  std::size_t NumUnknowns() const;
  // Throws km::NotObservable naming the counting condition (2) with its numbers, or a point
  // seen by fewer than 3 trackers.
  void CheckCounting() const;
  // Z_s of every segment: |u_z − U_j| from the current positions, or the free dead path
  // (state.offsets_mm must hold one entry per segment).
  std::vector<double> ZeroLengthsMm(const SelfCalState& state) const;
  // Sets state.offsets_mm to ZeroLengthsMm (resized to one entry per segment first).
  void UpdateZeroLengths(SelfCalState& state) const;
  // Residual of eq. (1) in µm (NaN for inactive readings).
  std::vector<double> ResidualsUm(const SelfCalState& state) const;
};

// Per-tracker initialisation from commanded points: solves |c_i − U| = d_i + L for U and L (an
// L per segment, also for those zeroed at a point: a start, selfcal_init.cpp),
// first in closed form (linear in U, L and |U|² − L²), then by Gauss-Newton over all of the
// tracker's segments; when the closed form is degenerate or fits badly, from starts on shells
// 0.4–1.6 m around the work volume. Returns the tracker position and its segment offsets.
struct TrackerInit {
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  std::vector<double> offsets_mm;  // per segment of this tracker, same order as problem segments
  double rms_um = 0.0;
};
TrackerInit InitialiseTracker(const SelfCalProblem& problem, const TrackerReadings& readings,
                              int tracker, const Eigen::Vector3d* guess_mm);

// Rigid (optionally mirrored) transform x ↦ R·x + t.
struct RigidTransform {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  bool mirrored = false;  // det(rotation) = −1
  Eigen::Vector3d Apply(const Eigen::Vector3d& x) const { return rotation * x + translation_mm; }
};

// The gauge frame of docs/formats.md §3 built from tracker positions 1, 2, 3, 4 (machine → gauge).
// Throws NotObservable when trackers 1–3 are (nearly) collinear or 4 lies in their plane.
RigidTransform GaugeTransform(const std::vector<Eigen::Vector3d>& trackers_mm);

// Least-squares fit of `from` onto `to` (Kabsch; picks the mirrored solution when it fits
// better, as distances cannot tell a frame from its mirror image). Weights optional.
RigidTransform FitRigid(const std::vector<Eigen::Vector3d>& from,
                        const std::vector<Eigen::Vector3d>& to,
                        const std::vector<char>* use = nullptr);

// Covariance of the least-squares estimate, from JᵀJ of the gauge-fixed problem reduced by the
// Schur complement over the point blocks (points eliminated as in bundle adjustment; the zero
// points of the interferometers stay with the trackers, selfcal_normal.h).
struct SelfCalCovariance {
  double sigma_um = 0.0;                         // a-posteriori reading σ (or the prior)
  double condition_number = 0.0;                 // of the reduced Jacobian (√ of normal matrix)
  std::vector<Eigen::Matrix3d> point_gauge_um2;  // in the gauge frame
  std::vector<Eigen::Matrix3d> point_free_um2;   // rigid motion of the point set removed
  std::vector<Eigen::Matrix3d> tracker_um2;      // gauge frame
  // Low-rank form of the full point covariance (gauge frame): Cov(u_i, u_k) =
  // δ_ik·point_block_um2[i] + coupling[i]·shared_um2·coupling[k]ᵀ (a zero point: block 0).
  std::vector<Eigen::Matrix3d> point_block_um2;
  std::vector<Eigen::MatrixXd> coupling;
  Eigen::MatrixXd shared_um2;
  int rank_deficiency = 0;
};
SelfCalCovariance ComputeCovariance(const SelfCalProblem& problem, const SelfCalState& state,
                                    double sigma_um);

}  // namespace km::tracker
