#include "analysis/tracker/selfcal_ceres.h"

#include <array>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include <ceres/ceres.h>

#include <Eigen/Geometry>

#include "analysis/core/option_check.h"
#include "analysis/tracker/selfcal_cost_ceres.h"

namespace km::tracker {

namespace {

// The internal gauge: three points in use spanning a large triangle (a: farthest from the
// centroid, b: farthest from a, c: farthest from the line ab). Returns false when the points
// are (nearly) collinear.
bool PickGaugePoints(const SelfCalProblem& problem, const SelfCalState& state,
                     std::array<int, 3>& abc) {
  const auto use = problem.PointsInUse();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double count = 0;
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (!use[i]) continue;
    centroid += state.points_mm[i];
    count += 1;
  }
  if (count < 3) return false;
  centroid /= count;
  auto farthest = [&](auto&& dist) {
    int best = -1;
    double best_d = -1;
    for (std::size_t i = 0; i < use.size(); ++i) {
      if (!use[i]) continue;
      const double d = dist(state.points_mm[i]);
      if (d > best_d) {
        best_d = d;
        best = static_cast<int>(i);
      }
    }
    return std::make_pair(best, best_d);
  };
  const int a = farthest([&](const Eigen::Vector3d& p) { return (p - centroid).norm(); }).first;
  const Eigen::Vector3d pa = state.points_mm[static_cast<std::size_t>(a)];
  const auto [b, ab] = farthest([&](const Eigen::Vector3d& p) { return (p - pa).norm(); });
  if (!(ab > 0)) return false;
  const Eigen::Vector3d ex = (state.points_mm[static_cast<std::size_t>(b)] - pa) / ab;
  const auto [c, off_line] = farthest([&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d v = p - pa;
    return (v - v.dot(ex) * ex).norm();
  });
  if (!(off_line > 1e-6 * ab)) return false;
  abc = {a, b, c};
  return true;
}

// Proper rigid motion taking a to the origin, b onto +x and c into the xy-plane (y > 0).
RigidTransform PointFrame(const SelfCalState& state, const std::array<int, 3>& abc) {
  const Eigen::Vector3d pa = state.points_mm[static_cast<std::size_t>(abc[0])];
  const Eigen::Vector3d ex = (state.points_mm[static_cast<std::size_t>(abc[1])] - pa).normalized();
  Eigen::Vector3d ey = state.points_mm[static_cast<std::size_t>(abc[2])] - pa;
  ey = (ey - ey.dot(ex) * ex).normalized();
  RigidTransform T;
  T.rotation.row(0) = ex.transpose();
  T.rotation.row(1) = ey.transpose();
  T.rotation.row(2) = ex.cross(ey).transpose();
  T.translation_mm = -T.rotation * pa;
  return T;
}

void Apply(const RigidTransform& T, SelfCalState& state) {
  for (auto& p : state.points_mm) p = T.Apply(p);
  for (auto& u : state.trackers_mm) u = T.Apply(u);
}

// The solver options of the self-calibration: Ceres' own, made once from the method's options,
// with the Schur ordering of the problem (points in group 0) added by the solve. Check()
// validates both before a solve.
struct SelfCalSolverOptions {
  CeresSolveOptions method;
  ceres::Solver::Options solver_options;

  explicit SelfCalSolverOptions(const CeresSolveOptions& options) : method(options) {
    solver_options.linear_solver_type =
        options.sparse_schur ? ceres::SPARSE_SCHUR : ceres::DENSE_SCHUR;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.num_threads = options.num_threads;
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.gradient_tolerance = options.gradient_tolerance;
    solver_options.parameter_tolerance = options.parameter_tolerance;
    solver_options.initial_trust_region_radius = options.initial_trust_region_radius;
    solver_options.logging_type = ceres::SILENT;
    solver_options.minimizer_progress_to_stdout = false;
  }

  void Check() const {
    method.Check();
    std::string why;
    if (!solver_options.IsValid(&why)) throw std::logic_error("ceres options: " + why);
  }
};

}  // namespace

void CeresSolveOptions::Check() const {
  KM_OPTION_GE(cauchy_scale_um, 0.0);
  KM_OPTION_GE(max_iterations, 1);
  KM_OPTION_GE(num_threads, 1);
  KM_OPTION_GT(initial_trust_region_radius, 0.0);
  KM_OPTION_GT(function_tolerance, 0.0);
  KM_OPTION_GT(gradient_tolerance, 0.0);
  KM_OPTION_GT(parameter_tolerance, 0.0);
}

CeresSolveReport SolveSelfCalCeres(const SelfCalProblem& problem, const CeresSolveOptions& options,
                                   SelfCalState& state) {
  // Gauge of the solve: three points (see selfcal_ceres.h), when they span a plane.
  std::array<int, 3> abc{};
  const bool point_gauge = PickGaugePoints(problem, state, abc);
  if (point_gauge) Apply(PointFrame(state, abc), state);
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
  if (point_gauge) {
    // a fixed, b on the x-axis, c in the xy-plane.
    problem_ceres.SetParameterBlockConstant(
        state.points_mm[static_cast<std::size_t>(abc[0])].data());
    problem_ceres.SetManifold(state.points_mm[static_cast<std::size_t>(abc[1])].data(),
                              new ceres::SubsetManifold(3, {1, 2}));
    problem_ceres.SetManifold(state.points_mm[static_cast<std::size_t>(abc[2])].data(),
                              new ceres::SubsetManifold(3, {2}));
  } else {
    // Collinear points (not observable; the covariance says so): the gauge of docs/formats.md §3.
    if (seen_tracker[0]) problem_ceres.SetParameterBlockConstant(state.trackers_mm[0].data());
    if (seen_tracker.size() > 1 && seen_tracker[1]) {
      problem_ceres.SetManifold(state.trackers_mm[1].data(), new ceres::SubsetManifold(3, {1, 2}));
    }
    if (seen_tracker.size() > 2 && seen_tracker[2]) {
      problem_ceres.SetManifold(state.trackers_mm[2].data(), new ceres::SubsetManifold(3, {2}));
    }
  }
  SelfCalSolverOptions solver(options);
  solver.solver_options.linear_solver_ordering = order;
  solver.Check();
  ceres::Solver::Summary summary;
  ceres::Solve(solver.solver_options, &problem_ceres, &summary);
  CeresSolveReport rep;
  rep.iterations = static_cast<int>(summary.iterations.size());
  rep.converged = summary.termination_type == ceres::CONVERGENCE;
  rep.final_cost = summary.final_cost;
  rep.message = summary.message;
  // Back to the gauge of docs/formats.md §3: tracker 1 at the origin, 2 on +x, 3 in the xy-plane,
  // z of 4 > 0.
  if (point_gauge) {
    Apply(GaugeTransform(state.trackers_mm), state);
    state.trackers_mm[0].setZero();
    state.trackers_mm[1].tail<2>().setZero();
    state.trackers_mm[2].z() = 0.0;
  }
  return rep;
}

}  // namespace km::tracker
