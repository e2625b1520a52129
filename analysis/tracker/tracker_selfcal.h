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

#include "analysis/tracker/selfcal_result.h"
#include "analysis/tracker/tracker_types.h"

namespace km::tracker {

// Throws km::NotObservable (counting condition, rank deficiency, condition number) or
// km::InvalidInput (inconsistent readings) or km::DidNotConverge. `solution` (optional) receives
// the solved problem.
SelfCalResult SelfCalibrate(const TrackerReadings& readings, const SelfCalOptions& options = {},
                            SelfCalSolution* solution = nullptr);

}  // namespace km::tracker
