#include "analysis/tracker/tracker_selfcal.h"

#include <utility>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"
#include "analysis/tracker/tracker_selfcal_stages.h"

namespace km::tracker {

void SelfCalOptions::Check() const {
  KM_OPTION_GT(outlier_k, 1.0);
  KM_OPTION_GE(outlier_floor_um, 0.0);
  KM_OPTION_GE(max_rejection_rounds, 0);
  KM_OPTION_GE(robust_scale_um, 0.0);
  KM_OPTION_GE(max_iterations, 1);
  KM_OPTION_GT(max_condition_number, 1.0);
  KM_OPTION_GT(prior_sigma_um, 0.0);
}

// The pipeline of [Tracker paper] §4 as named stages (tracker_selfcal_stages.cpp).
SelfCalResult SelfCalibrate(const TrackerReadings& readings, const SelfCalOptions& options,
                            SelfCalSolution* solution) {
  using namespace selfcal_stages;
  options.Check();
  CheckReadings(readings);
  SelfCalProblem problem = SelfCalProblem::FromReadings(readings);
  problem.CheckCounting();

  SelfCalResult res;
  res.mode = readings.mode;
  SelfCalState state = Initialise(problem, readings, res);
  // Plain least squares first, then the robust (Cauchy) pass from there, then rejection rounds
  // with least-squares re-solves.
  SolveProgress solve = LeastSquaresPass(problem, options, state, res);
  RobustPass(problem, options, state, solve, res);
  RejectionRounds(problem, readings, options, state, solve, res);
  FixGaugeSign(state);
  const SelfCalCovariance cov = Precision(problem, state, options, res);
  AssembleResult(problem, readings, state, cov, res);
  SpatialWarning(problem, readings, state, options, res);
  if (solution) *solution = {std::move(problem), std::move(state), solve.options};
  return res;
}

}  // namespace km::tracker
