#include "analysis/tracker/selfcal_ceres.h"

#include <memory>
#include <stdexcept>

#include <ceres/ceres.h>

#include "analysis/tracker/selfcal_cost.h"

namespace km::tracker {

CeresSolveReport SolveSelfCalCeres(const SelfCalProblem& problem, const CeresSolveOptions& options,
                                   SelfCalState& state) {
  ceres::Problem::Options popt;
  // One loss shared by every residual block, owned here (not by the problem).
  std::unique_ptr<ceres::LossFunction> loss_owner;
  if (options.cauchy_scale_um > 0) loss_owner.reset(new ceres::CauchyLoss(options.cauchy_scale_um));
  ceres::LossFunction* loss = loss_owner.get();
  popt.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem_ceres(popt);
  auto order = std::make_shared<ceres::ParameterBlockOrdering>();
  std::vector<char> seen_point(state.points_mm.size(), 0);
  std::vector<char> seen_tracker(state.trackers_mm.size(), 0);
  for (std::size_t k = 0; k < problem.observations.size(); ++k) {
    if (!problem.active[k]) continue;
    const auto& o = problem.observations[k];
    double* u = state.points_mm[static_cast<std::size_t>(o.point)].data();
    double* U = state.trackers_mm[static_cast<std::size_t>(o.tracker)].data();
    double* L = &state.offsets_mm[static_cast<std::size_t>(o.segment)];
    problem_ceres.AddResidualBlock(DistanceReadingAnalyticCost::Create(o.d_mm), loss, u, U, L);
    if (!seen_point[static_cast<std::size_t>(o.point)]) {
      seen_point[static_cast<std::size_t>(o.point)] = 1;
      order->AddElementToGroup(u, 0);
    }
    if (!seen_tracker[static_cast<std::size_t>(o.tracker)]) {
      seen_tracker[static_cast<std::size_t>(o.tracker)] = 1;
      order->AddElementToGroup(U, 1);
    }
    order->AddElementToGroup(L, 1);
  }
  // Gauge (contract §3): tracker 1 at the origin, 2 on +x, 3 in the xy-plane.
  if (seen_tracker[0]) problem_ceres.SetParameterBlockConstant(state.trackers_mm[0].data());
  if (seen_tracker.size() > 1 && seen_tracker[1]) {
    problem_ceres.SetManifold(state.trackers_mm[1].data(), new ceres::SubsetManifold(3, {1, 2}));
  }
  if (seen_tracker.size() > 2 && seen_tracker[2]) {
    problem_ceres.SetManifold(state.trackers_mm[2].data(), new ceres::SubsetManifold(3, {2}));
  }
  ceres::Solver::Options so;
  so.linear_solver_type = options.sparse_schur ? ceres::SPARSE_SCHUR : ceres::DENSE_SCHUR;
  so.linear_solver_ordering = order;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = options.num_threads;
  // Lengths are ~1e3 mm and readings good to ~1e-4 mm: 1e-10 relative is far below the noise.
  so.function_tolerance = 1e-10;
  so.gradient_tolerance = 1e-12;
  so.parameter_tolerance = 1e-10;
  so.initial_trust_region_radius = options.initial_trust_region_radius;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  std::string why;
  if (!so.IsValid(&why)) throw std::logic_error("ceres options: " + why);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem_ceres, &summary);
  CeresSolveReport rep;
  rep.iterations = static_cast<int>(summary.iterations.size());
  rep.converged = summary.termination_type == ceres::CONVERGENCE;
  rep.final_cost = summary.final_cost;
  rep.message = summary.message;
  return rep;
}

}  // namespace km::tracker
