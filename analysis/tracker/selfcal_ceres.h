// Ceres-specific solve of the self-calibration problem described in selfcal_problem.h:
// Levenberg-Marquardt with the Schur complement (point blocks in elimination group 0, trackers
// and dead paths in group 1, as in bundle adjustment).
//
// Gauge of the solve: three points in use spanning a large triangle — a held (constant block),
// b on the x-axis and c in the xy-plane of a frame they define (subset manifolds) — and the
// result is then moved into the gauge of docs/formats.md §3 (tracker 1 at the origin, 2 on +x, 3 in
// the xy-plane, z of 4 > 0) by a rigid motion, which changes no distance. Fixing the gauge on
// trackers 1–3 instead turns the weakly determined motion of a far tracker along its line of
// sight into a rotation of the whole point cloud about tracker 1, metres away: a curved valley
// that Levenberg–Marquardt descends a few mm per iteration (100 mm cube, trackers 2.5–6 m: still
// 1–1.6 µm short of the optimum after 100 iterations). In the point gauge that valley is
// straight. Collinear points (not observable anyway) fall back to the tracker gauge.
#pragma once

#include "analysis/tracker/selfcal_problem.h"

namespace km::tracker {

// The method's options of a solve; the Ceres solver options are made from them in
// selfcal_ceres.cpp (SelfCalSolverOptions), so no Ceres type appears outside that file.
struct CeresSolveOptions {
  double cauchy_scale_um = 0.0;  // > 0: Cauchy loss with this scale (µm); 0: plain least squares
  int max_iterations = 100;
  int num_threads = 1;
  double initial_trust_region_radius = 1e4;  // large for warm re-solves
  bool sparse_schur = false;  // DENSE_SCHUR (default: the reduced system is tiny) or SPARSE_SCHUR
  // Lengths are ~1e3 mm and readings good to ~1e-4 mm: 1e-10 relative is far below the noise.
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-12;
  double parameter_tolerance = 1e-10;

  // Throws km::InvalidInput naming the bad option (analysis/core/option_check.h).
  void Check() const;
};

struct CeresSolveReport {
  int iterations = 0;
  bool converged = false;
  double final_cost = 0.0;
  std::string message;
};

// Refines `state` (already in the gauge frame) over the active readings of `problem`.
CeresSolveReport SolveSelfCalCeres(const SelfCalProblem& problem, const CeresSolveOptions& options,
                                   SelfCalState& state);

}  // namespace km::tracker
