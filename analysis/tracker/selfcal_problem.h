// Problem description of the multilateration self-calibration ([Tracker paper] §4), separate from
// the Ceres-specific solve (selfcal_ceres.h).
//
// Unknowns: target positions u_i (3m), tracker positions U_j (3n) and one dead-path length L_s
// per interferometer segment (one per tracker, plus one per beam break). Each reading gives
//
//   r_ij = |u_i − U_j| − L_s(i,j) − d_ij                                          (1)
//
// which, with L_s = |u_1 − U_j| for the first segment, is [Tracker paper] eq. 1 written with an
// explicit offset (the least-squares solution of eq. 2 with independent reading noise). The
// seven-parameter gauge of distances (rigid motion and mirror image) is fixed as in [Tracker paper]
// and docs/formats.md §3: U_1 = 0, U_2 on +x (V_2 = W_2 = 0), U_3 in the xy-plane with V_3 > 0, and
// W_4 > 0. Counting unknowns: with m points, n trackers and b beam breaks there are
// 3m + (3n − 6) + (n + b) of them, so the m·n readings must satisfy
//
//   m·n ≥ 3m + 4n − 6 + b                                                         (2)
//
// ([Tracker paper] lists p = [U2 U3 V3 U4 V4 W4 u1ᵀ … umᵀ] for n = 4; the n offsets are the |u_1 −
// U_j| that eq. 1 subtracts). n = 3 never satisfies (2); n = 4 needs m ≥ 10 points. The count is
// necessary, not sufficient: all trackers in one plane ([Tracker paper]'s set-up, four trackers on
// the table) leave one direction of the tracker/dead-path parameters free, and nearly coplanar
// trackers make the solution very uncertain; so do collinear points. The solver checks the
// rank and condition of the Schur-reduced normal matrix (ComputeCovariance).
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
  int segment = 0;  // index into SelfCalState::offsets_mm
  double d_mm = 0.0;
};

// Current values of all unknowns (gauge frame once the gauge is applied).
struct SelfCalState {
  std::vector<Eigen::Vector3d> trackers_mm;
  std::vector<Eigen::Vector3d> points_mm;
  std::vector<double> offsets_mm;  // dead path L_s per segment
};

// The fixed description: observations, segments, which readings are active.
struct SelfCalProblem {
  int num_points = 0;
  int num_trackers = 0;
  std::vector<Observation> observations;
  std::vector<int> segment_tracker;  // tracker of each segment
  std::vector<char> active;          // per observation (rejected or missing readings = 0)

  // Builds the observation list from the readings; missing (non-finite) readings are skipped.
  static SelfCalProblem FromReadings(const TrackerReadings& readings);

  int NumSegments() const { return static_cast<int>(segment_tracker.size()); }
  // Points that still have at least one active reading.
  std::vector<char> PointsInUse() const;
  std::size_t NumActive() const;
  // Unknowns of eq. (2) for the points in use.
  std::size_t NumUnknowns() const;
  // Throws km::NotObservable naming the counting condition (2) with its numbers, or a point
  // with fewer than 3 active readings.
  void CheckCounting() const;
  // Residual of eq. (1) in µm (NaN for inactive readings).
  std::vector<double> ResidualsUm(const SelfCalState& state) const;
};

// Per-tracker initialisation from commanded points: solves |c_i − U| = d_i + L for U and L,
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
// Schur complement over the point blocks (points eliminated as in bundle adjustment).
struct SelfCalCovariance {
  double sigma_um = 0.0;                         // a-posteriori reading σ (or the prior)
  double condition_number = 0.0;                 // of the reduced Jacobian (√ of normal matrix)
  std::vector<Eigen::Matrix3d> point_gauge_um2;  // in the gauge frame
  std::vector<Eigen::Matrix3d> point_free_um2;   // rigid motion of the point set removed
  std::vector<Eigen::Matrix3d> tracker_um2;      // gauge frame
  // Low-rank form of the full point covariance (gauge frame): Cov(u_i, u_k) =
  // δ_ik·point_block_um2[i] + coupling[i]·shared_um2·coupling[k]ᵀ.
  std::vector<Eigen::Matrix3d> point_block_um2;
  std::vector<Eigen::MatrixXd> coupling;
  Eigen::MatrixXd shared_um2;
  int rank_deficiency = 0;
};
SelfCalCovariance ComputeCovariance(const SelfCalProblem& problem, const SelfCalState& state,
                                    double sigma_um);

}  // namespace km::tracker
