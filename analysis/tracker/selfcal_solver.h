// Least-squares solve of the self-calibration problem described in selfcal_problem.h:
// Levenberg–Marquardt on [Tracker paper] eqs. 2–4 (Gauss–Newton, Δd = A·Δp, with Marquardt's
// damping), each step by the Schur complement of the block-arrow normal equations
// (selfcal_normal.h): the 3×3 block of every point that is no interferometer's zero is
// eliminated, and the small system of the trackers, zero points and free dead paths is solved
// densely — as in bundle adjustment, in O(readings) a step.
//
// Gauge of the solve: three eliminated points spanning a large triangle — a held, b moving along
// the x-axis only and c in the xy-plane of a frame they define — and the result is then moved
// into the gauge of docs/formats.md §3 (tracker 1 at the origin, 2 on +x, 3 in the xy-plane, z of
// 4 > 0) by a rigid motion, which changes no distance. Fixing the gauge on trackers 1–3 instead
// turns the weakly determined motion of a far tracker along its line of sight into a rotation of
// the whole point cloud about tracker 1, metres away: a curved valley that Levenberg–Marquardt
// descends a few mm per iteration (100 mm cube, trackers 2.5–6 m: still 1–1.6 µm short of the
// optimum after 100 iterations). In the point gauge that valley is straight. Collinear points
// (not observable anyway) fall back to the tracker gauge.
#pragma once

#include <string>

#include "analysis/tracker/selfcal_problem.h"

namespace km::tracker {

struct SolveOptions {
  double cauchy_scale_um = 0.0;  // > 0: Cauchy loss with this scale (µm); 0: plain least squares
  int max_iterations = 100;
  // Marquardt's damping is diag(JᵀJ)/radius: large = close to a Gauss–Newton step (warm starts).
  double initial_trust_region_radius = 1e4;
  // Converged when the quadratic model promises less than tol·cost (the cost's own rounding:
  // along the weak directions of far trackers a decrease of 1e-10·cost is still 0.1 µm away),
  double function_tolerance = 1e-13;
  // or a successful step moves no coordinate by more than tol·(largest coordinate + tol)
  // (lengths ~1e3 mm: 0.1 nm),
  double parameter_tolerance = 1e-10;
  // or max |Jᵀr| (µm²/mm) is below this.
  double gradient_tolerance = 1e-12;
  // One round of iterative refinement of each step (the reduced matrix loses digits where far
  // trackers make it ill-conditioned); a robust pass that only exposes gross errors needs none.
  bool refine_steps = true;

  // Throws km::InvalidInput naming the bad option (analysis/core/option_check.h).
  void Check() const;
};

struct SolveReport {
  int iterations = 0;  // steps tried, successful or not
  bool converged = false;
  double final_cost = 0.0;  // ½ Σ ρ(r²), r in µm
  std::string message;
};

// Refines `state` (already in the gauge frame) over the active readings of `problem`; on return
// the state is in the gauge of docs/formats.md §3 and its zero lengths are up to date.
SolveReport SolveSelfCal(const SelfCalProblem& problem, const SolveOptions& options,
                         SelfCalState& state);

}  // namespace km::tracker
