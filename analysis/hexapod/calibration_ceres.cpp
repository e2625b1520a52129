// Ceres solve of a CalibrationProblem (see calibration.h). Only this file knows Ceres types.
#include <memory>

#include <ceres/ceres.h>

#include "analysis/core/errors.h"
#include "analysis/hexapod/calibration.h"
#include "analysis/hexapod/calibration_cost.h"

namespace km::hexapod {

CalibrationResult SolveCalibration(const CalibrationProblem& problem) {
  problem.options.Check();
  ParameterVector k = ParameterVector::Zero();
  std::vector<Eigen::Vector3d> balls;
  balls.reserve(problem.tests.size());
  for (const auto& t : problem.tests) balls.push_back(t.fixed_ball_mm);

  ceres::Problem::Options popts;
  popts.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem cp(popts);
  for (std::size_t ti = 0; ti < problem.tests.size(); ++ti) {
    const auto& t = problem.tests[ti];
    for (const auto& s : t.samples) {
      cp.AddResidualBlock(BarLengthCost::Create(&problem.nominal, &s, t.tool_length_mm), nullptr,
                          k.data(), balls[ti].data());
    }
    if (t.fixed_ball_known) {
      cp.SetParameterBlockConstant(balls[ti].data());
    } else if (t.ball_fixed_axis >= 0) {
      cp.SetManifold(balls[ti].data(), new ceres::SubsetManifold(3, {t.ball_fixed_axis}));
    }
  }
  std::vector<int> fixed;
  for (int i = 0; i < kNumKinematicParameters; ++i) {
    if (problem.fixed[i]) fixed.push_back(i);
  }
  if (static_cast<int>(fixed.size()) == kNumKinematicParameters) {
    cp.SetParameterBlockConstant(k.data());
  } else if (!fixed.empty()) {
    cp.SetManifold(k.data(), new ceres::SubsetManifold(kNumKinematicParameters, fixed));
  }

  ceres::Solver::Options so;
  // Centre-corrected: the per-test fixed balls are eliminated by the Schur complement (they
  // share no residual), leaving a 24×24 reduced system; absolute: 24 columns, dense QR.
  bool any_free_ball = false;
  for (const auto& t : problem.tests) any_free_ball = any_free_ball || !t.fixed_ball_known;
  if (any_free_ball) {
    so.linear_solver_type = ceres::DENSE_SCHUR;
    auto* ordering = new ceres::ParameterBlockOrdering;
    for (std::size_t ti = 0; ti < problem.tests.size(); ++ti) {
      if (!problem.tests[ti].fixed_ball_known) ordering->AddElementToGroup(balls[ti].data(), 0);
    }
    ordering->AddElementToGroup(k.data(), 1);
    so.linear_solver_ordering.reset(ordering);
  } else {
    so.linear_solver_type = ceres::DENSE_QR;
  }
  // The model is nearly linear over the parameter range ([PM-600 report] iterates plain
  // Gauss–Newton): start with a wide trust region so the first steps are full Gauss–Newton steps.
  so.initial_trust_region_radius = 1e10;
  // Dogleg: the Gauss–Newton model of this problem is accurate ([PM-600 report] eqs. 2.2–2.5
  // iterate plain Gauss–Newton); Levenberg–Marquardt was seen to stall in centre-corrected mode.
  so.trust_region_strategy_type = ceres::DOGLEG;
  so.max_num_iterations = problem.options.max_iterations;
  so.function_tolerance = problem.options.function_tolerance;
  so.parameter_tolerance = problem.options.parameter_tolerance;
  so.gradient_tolerance = 1e-12;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &cp, &summary);
  if (!summary.IsSolutionUsable()) {
    throw DidNotConverge("hexapod calibration failed: " + summary.message);
  }

  CalibrationResult result;
  result.method = problem.options.method;
  result.parameters_um = k;
  result.fixed_balls_mm = balls;
  result.fixed_parameter_indices = fixed;
  for (int i : fixed) result.fixed_parameters.push_back(ParameterName(i));
  result.singular_values = problem.singular_values;
  result.iterations = static_cast<int>(summary.iterations.size());
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.calibrated = ApplyParameters(problem.nominal, k);
  internal::FillStatistics(problem, result);
  return result;
}

}  // namespace km::hexapod
