// Ceres solve of a CalibrationProblem (see calibration.h). Only this file knows Ceres types.
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "analysis/core/errors.h"
#include "analysis/hexapod/calibration.h"
#include "analysis/hexapod/calibration_cost.h"

namespace km::hexapod {
namespace {

class BarLengthCost : public ceres::SizedCostFunction<1, kNumKinematicParameters, 3> {
 public:
  BarLengthCost(const HexapodGeometry* nominal, const CalibrationSample* sample,
                double tool_length_mm)
      : nominal_(nominal), sample_(sample), tool_length_mm_(tool_length_mm) {}

  static ceres::CostFunction* Create(const HexapodGeometry* nominal,
                                     const CalibrationSample* sample, double tool_length_mm) {
    return new BarLengthCost(nominal, sample, tool_length_mm);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    return EvaluateBarSample(*nominal_, *sample_, tool_length_mm_, parameters[0], parameters[1],
                             residuals, jacobians ? jacobians[0] : nullptr,
                             jacobians ? jacobians[1] : nullptr);
  }

 private:
  const HexapodGeometry* nominal_;
  const CalibrationSample* sample_;
  double tool_length_mm_;
};

// The solver options of the calibration: Ceres' own, made once from the method's options
// (iterations, tolerances, trust region), and the linear solver the problem's structure asks for
// (SetLinearSolver). Check() validates both before a solve.
struct CalibrationSolverOptions {
  CalibrationOptions method;
  ceres::Solver::Options solver_options;

  explicit CalibrationSolverOptions(const CalibrationOptions& options) : method(options) {
    // Dogleg: the Gauss–Newton model of this problem is accurate ([PM-600 report] eqs. 2.2–2.5
    // iterate plain Gauss–Newton); Levenberg–Marquardt was seen to stall in centre-corrected
    // mode.
    solver_options.trust_region_strategy_type = ceres::DOGLEG;
    solver_options.initial_trust_region_radius = options.initial_trust_region_radius;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.parameter_tolerance = options.parameter_tolerance;
    solver_options.gradient_tolerance = options.gradient_tolerance;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    solver_options.minimizer_progress_to_stdout = false;
  }

  void Check() const {
    method.Check();
    std::string why;
    if (!solver_options.IsValid(&why)) throw std::logic_error("ceres options: " + why);
  }
};

// Centre-corrected: the per-test fixed balls are eliminated by the Schur complement (they share
// no residual), leaving a 24×24 reduced system; absolute: 24 columns, dense QR.
void SetLinearSolver(const CalibrationProblem& problem, std::vector<Eigen::Vector3d>& balls,
                     ParameterVector& k, ceres::Solver::Options& so) {
  bool any_free_ball = false;
  for (const auto& t : problem.tests) any_free_ball = any_free_ball || !t.fixed_ball_known;
  if (!any_free_ball) {
    so.linear_solver_type = ceres::DENSE_QR;
    return;
  }
  so.linear_solver_type = ceres::DENSE_SCHUR;
  auto* ordering = new ceres::ParameterBlockOrdering;
  for (std::size_t ti = 0; ti < problem.tests.size(); ++ti) {
    if (!problem.tests[ti].fixed_ball_known) ordering->AddElementToGroup(balls[ti].data(), 0);
  }
  ordering->AddElementToGroup(k.data(), 1);
  so.linear_solver_ordering.reset(ordering);
}

}  // namespace

CalibrationResult SolveCalibration(const CalibrationProblem& problem) {
  CalibrationSolverOptions options(problem.options);
  options.Check();
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

  SetLinearSolver(problem, balls, k, options.solver_options);
  ceres::Solver::Summary summary;
  ceres::Solve(options.solver_options, &cp, &summary);
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
