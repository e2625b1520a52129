// Uncertainty of the self-calibration's figures from the stated uncertainty of the trackers'
// ranging readings (`u_ranging_um`, k = 1, normal, independent per reading; docs/formats.md §1.2),
// propagated by Monte Carlo ([JCGM 101] §7, analysis/uncertainty/) through the same least-squares
// solve, not through a linearised formula (docs/methods.md §16.5).
//
// Each draw adds an independent N(0, u²) to every reading in use (one group input of the
// propagation, one budget entry) and re-solves [Tracker paper] eq. (1) with the solver of the
// self-calibration (SolveSelfCal), warm-started from the base solution, over the same readings:
// the readings the base solve rejected stay out, nothing is rejected anew (a draw of
// N(0, u²) noise is no gross error). From each re-solve, as the result is made: the gauge sign
// (z of tracker 4 > 0), the best rigid fit of the points to the commanded ones, the volumetric
// errors, their largest norm, the rms residual, the tracker positions and the segments' distances
// to their zeros.
//
// The first-order check ([JCGM 100] §5.1) beside it: the least-squares covariance u²·(JᵀJ)⁻¹ of
// the same problem (ComputeCovariance with the reading σ = u) for the tracker positions and the
// volumetric errors; the largest error, the rms residual and the dead paths have none (NaN).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_types.h"
#include "analysis/uncertainty/monte_carlo.h"

namespace km::tracker {

struct RangingUncertaintyOptions {
  // M = 500: the standard error of u is about 1/√(2M) = 3.2 % of u for a normal output (U's
  // statistical error well under 5 %); a re-solve costs about 1 ms for 64 points and 25 ms for
  // 1 000 (docs/methods.md §16.5).
  std::size_t draws = 500;
  std::uint64_t seed = 3817;
  // The 95 % interval needs M ≥ 1/(1 − p) = 20 draws ([JCGM 101] §7.2).
  void Check() const;  // throws km::InvalidInput naming the option out of its range
};

struct RangingUncertainty {
  // Outputs: first the figures (figure_keys, in µm: a coordinate in mm as 1000·mm), then three
  // per point in use (the volumetric error's x, y, z in µm) from point_output[i] on.
  uncertainty::McResult mc;
  std::vector<std::string> figure_keys;
  // Per figure, what the result gives it as: "none", or the tracker (0-based) and axis whose
  // least-squares σ is SelfCalResult::tracker_uncertainty_um[tracker](axis).
  std::vector<int> figure_tracker;
  std::vector<int> figure_axis;
  std::vector<double> figure_value_um;  // the base result's value (µm)
  std::vector<double> u_gum_um;         // first-order u per output (NaN: none)
  std::vector<int> point_output;        // per point: its first output, −1 when dropped
  std::size_t readings = 0;             // readings drawn (the group's count)
};

// The largest norm of the volumetric errors of the points in use (µm; NaN when there is none).
double VolumetricErrorMaxUm(const SelfCalResult& result);

// The propagation of u_ranging_um (> 0) through the solution `solution` of `result`. Throws
// km::DidNotConverge when a draw's solve fails (readings so uncertain that the survey falls
// apart), km::InvalidInput for bad options.
RangingUncertainty PropagateRangingUncertainty(const TrackerReadings& readings,
                                               const SelfCalResult& result,
                                               const SelfCalSolution& solution, double u_ranging_um,
                                               const RangingUncertaintyOptions& options = {});

}  // namespace km::tracker
