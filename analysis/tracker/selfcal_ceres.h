// Ceres-specific solve of the self-calibration problem described in selfcal_problem.h:
// Levenberg-Marquardt with the Schur complement (point blocks in elimination group 0, trackers
// and dead paths in group 1, as in bundle adjustment), gauge fixed by a constant block for
// tracker 1 and subset manifolds for trackers 2 and 3.
#pragma once

#include "analysis/tracker/selfcal_problem.h"

namespace km::tracker {

struct CeresSolveOptions {
  double cauchy_scale_um = 0.0;  // > 0: Cauchy loss with this scale (µm); 0: plain least squares
  int max_iterations = 100;
  int num_threads = 1;
  double initial_trust_region_radius = 1e4;  // large for warm re-solves
  bool sparse_schur = false;  // DENSE_SCHUR (default: the reduced system is tiny) or SPARSE_SCHUR
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
