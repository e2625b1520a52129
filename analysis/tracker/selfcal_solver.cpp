#include "analysis/tracker/selfcal_solver.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Cholesky>

#include "analysis/core/option_check.h"
#include "analysis/tracker/selfcal_normal.h"

namespace km::tracker {

namespace {

using selfcal_normal::ColumnLayout;
using selfcal_normal::Gauge;
using selfcal_normal::NormalEquations;
using selfcal_normal::RowMajorMatrix;

// The internal gauge: three points that can be eliminated (in use, no zero point) spanning a
// large triangle (a: farthest from the centroid, b: farthest from a, c: farthest from the line
// ab). Returns false when they are (nearly) collinear.
bool PickGaugePoints(const SelfCalProblem& problem, const SelfCalState& state,
                     std::array<int, 3>& abc) {
  std::vector<char> use = problem.PointsInUse();
  const auto seg_use = problem.SegmentsInUse();
  for (std::size_t s = 0; s < problem.segments.size(); ++s) {
    const int z = problem.segments[s].zero_point;
    if (seg_use[s] && z >= 0) use[static_cast<std::size_t>(z)] = 0;
  }
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

// ½ Σ ρ(r²) over the active readings; the robust weights ρ'(r²) when asked.
double Cost(const SelfCalProblem& problem, const SelfCalState& state, double cauchy_um,
            std::vector<double>* weights) {
  const std::vector<double> r = problem.ResidualsUm(state);
  const double b = cauchy_um * cauchy_um;
  double cost = 0;
  if (weights) weights->assign(r.size(), 1.0);
  for (std::size_t k = 0; k < r.size(); ++k) {
    if (!problem.active[k]) continue;
    const double s = r[k] * r[k];
    if (b > 0) {
      cost += 0.5 * b * std::log1p(s / b);
      if (weights) (*weights)[k] = 1.0 / (1.0 + s / b);
    } else {
      cost += 0.5 * s;
    }
  }
  return cost;
}

struct Step {
  Eigen::VectorXd points;  // 3 per eliminated point
  Eigen::VectorXd global;
};

// Marquardt's scaling: the diagonal of JᵀJ, kept within [1e-6, 1e32] as in Ceres.
double Scaling(double d) {
  return std::clamp(d, 1e-6, 1e32);
}

// (JᵀJ + diag(JᵀJ)/radius) factorised by eliminating the point blocks: A_e = L_e L_eᵀ (damped),
// W_e = L_e⁻¹E_e, and the reduced matrix F − WᵀW (damped) by LDLᵀ.
struct Factorisation {
  double radius = 1.0;
  std::vector<Eigen::Matrix3d> L;
  RowMajorMatrix W;
  Eigen::LDLT<Eigen::MatrixXd> reduced;
};

bool Factorise(const NormalEquations& ne, double radius, Factorisation& f) {
  const auto ne_count = static_cast<Eigen::Index>(ne.A.size());
  const Eigen::Index c = ne.F.rows();
  f.radius = radius;
  f.L.resize(ne.A.size());
  f.W.resize(3 * ne_count, c);
  for (Eigen::Index e = 0; e < ne_count; ++e) {
    Eigen::Matrix3d Ad = ne.A[static_cast<std::size_t>(e)];
    for (int a = 0; a < 3; ++a) Ad(a, a) += Scaling(Ad(a, a)) / radius;
    const Eigen::LLT<Eigen::Matrix3d> llt(Ad);
    if (llt.info() != Eigen::Success) return false;
    f.L[static_cast<std::size_t>(e)] = llt.matrixL();
    f.W.middleRows<3>(3 * e) =
        f.L[static_cast<std::size_t>(e)].triangularView<Eigen::Lower>().solve(
            ne.E.middleRows<3>(3 * e));
  }
  Eigen::MatrixXd S = ne.F;
  for (Eigen::Index a = 0; a < c; ++a) S(a, a) += Scaling(S(a, a)) / radius;
  S.selfadjointView<Eigen::Lower>().rankUpdate(f.W.transpose(), -1.0);
  f.reduced.compute(S.selfadjointView<Eigen::Lower>());
  return f.reduced.info() == Eigen::Success;
}

// δ with (JᵀJ + D/radius)·δ = −g: the reduced system (F − WᵀW)·δ_c = −(g_c − Wᵀw),
// w_e = L_e⁻¹g_e, then δ_e = −L_e⁻ᵀ(w_e + W_e δ_c).
void Solve(const Factorisation& f, const Eigen::VectorXd& g_points, const Eigen::VectorXd& g,
           Step& step) {
  const auto ne_count = static_cast<Eigen::Index>(f.L.size());
  Eigen::VectorXd w(3 * ne_count);
  for (Eigen::Index e = 0; e < ne_count; ++e) {
    w.segment<3>(3 * e) = f.L[static_cast<std::size_t>(e)].triangularView<Eigen::Lower>().solve(
        g_points.segment<3>(3 * e));
  }
  step.global = -f.reduced.solve(g - f.W.transpose() * w);
  const Eigen::VectorXd back = w + f.W * step.global;
  step.points.resize(3 * ne_count);
  for (Eigen::Index e = 0; e < ne_count; ++e) {
    step.points.segment<3>(3 * e) =
        -f.L[static_cast<std::size_t>(e)].triangularView<Eigen::Lower>().transpose().solve(
            back.segment<3>(3 * e));
  }
}

// (JᵀJ + D/radius)·δ from the blocks (sums of the rows: exact where F − WᵀW cancels).
Step Product(const NormalEquations& ne, double radius, const Step& d) {
  Step out;
  out.points = ne.E * d.global;
  out.global = ne.F.selfadjointView<Eigen::Lower>() * d.global;
  out.global.noalias() += ne.E.transpose() * d.points;
  for (Eigen::Index a = 0; a < d.global.size(); ++a) {
    out.global(a) += Scaling(ne.F(a, a)) / radius * d.global(a);
  }
  for (std::size_t e = 0; e < ne.A.size(); ++e) {
    const auto k = 3 * static_cast<Eigen::Index>(e);
    Eigen::Matrix3d Ad = ne.A[e];
    for (int a = 0; a < 3; ++a) Ad(a, a) += Scaling(Ad(a, a)) / radius;
    out.points.segment<3>(k) += Ad * d.points.segment<3>(k);
  }
  return out;
}

// The damped step, with one round of iterative refinement: with far trackers F − WᵀW loses
// digits to cancellation, and the step along the weakly determined directions with them.
bool SolveDamped(const NormalEquations& ne, double radius, Factorisation& f, Step& step) {
  if (!Factorise(ne, radius, f)) return false;
  Solve(f, ne.g_points, ne.g, step);
  const Step hd = Product(ne, radius, step);
  Step correction;
  Solve(f, ne.g_points + hd.points, ne.g + hd.global, correction);
  step.points += correction.points;
  step.global += correction.global;
  return step.points.allFinite() && step.global.allFinite();
}

// Decrease of the quadratic model: −(gᵀδ + ½ δᵀ JᵀJ δ).
double ModelDecrease(const NormalEquations& ne, const Step& step) {
  const Eigen::VectorXd Ed = ne.E * step.global;
  double quad = step.global.dot(ne.F.selfadjointView<Eigen::Lower>() * step.global) +
                2.0 * step.points.dot(Ed);
  for (std::size_t e = 0; e < ne.A.size(); ++e) {
    const auto d = step.points.segment<3>(3 * static_cast<Eigen::Index>(e));
    quad += d.dot(ne.A[e] * d);
  }
  return -(ne.g.dot(step.global) + ne.g_points.dot(step.points) + 0.5 * quad);
}

void ApplyStep(const ColumnLayout& L, const Step& step, SelfCalState& s) {
  for (int e = 0; e < L.NumEliminated(); ++e) {
    s.points_mm[static_cast<std::size_t>(L.eliminated_point[static_cast<std::size_t>(e)])] +=
        step.points.segment<3>(3 * e);
  }
  auto add3 = [&](const std::array<int, 3>& col, Eigen::Vector3d& x) {
    for (int a = 0; a < 3; ++a) {
      if (col[static_cast<std::size_t>(a)] >= 0)
        x(a) += step.global(col[static_cast<std::size_t>(a)]);
    }
  };
  for (std::size_t j = 0; j < s.trackers_mm.size(); ++j)
    add3(L.tracker_column[j], s.trackers_mm[j]);
  for (std::size_t i = 0; i < s.points_mm.size(); ++i) add3(L.point_column[i], s.points_mm[i]);
  for (std::size_t q = 0; q < L.offset_column.size(); ++q) {
    if (L.offset_column[q] >= 0) s.offsets_mm[q] += step.global(L.offset_column[q]);
  }
}

double ParameterNorm(const ColumnLayout& L, const SelfCalState& s) {
  double n2 = 0;
  for (int p : L.eliminated_point) n2 += s.points_mm[static_cast<std::size_t>(p)].squaredNorm();
  for (const auto& u : s.trackers_mm) n2 += u.squaredNorm();
  for (std::size_t q = 0; q < L.offset_column.size(); ++q) {
    if (L.offset_column[q] >= 0) n2 += s.offsets_mm[q] * s.offsets_mm[q];
  }
  return std::sqrt(n2);
}

double GradientMax(const NormalEquations& ne) {
  const double a = ne.g.size() ? ne.g.cwiseAbs().maxCoeff() : 0.0;
  const double b = ne.g_points.size() ? ne.g_points.cwiseAbs().maxCoeff() : 0.0;
  return std::max(a, b);
}

// Levenberg–Marquardt with Nielsen's update of the damping radius (the strategy of Ceres).
SolveReport Minimise(const SelfCalProblem& problem, const SolveOptions& o, const ColumnLayout& L,
                     SelfCalState& state) {
  SolveReport rep;
  const double b = o.cauchy_scale_um;
  std::vector<double> weights;
  std::vector<double>* wp = b > 0 ? &weights : nullptr;
  double cost = Cost(problem, state, b, wp);
  NormalEquations ne;
  selfcal_normal::Build(problem, L, state, wp, ne);
  Factorisation factorisation;
  Step step;
  double radius = o.initial_trust_region_radius;
  double nu = 2.0;
  rep.message = "iteration limit";
  if (GradientMax(ne) <= o.gradient_tolerance) {
    rep.converged = true;
    rep.message = "gradient below tolerance";
  }
  SelfCalState trial = state;
  while (!rep.converged && rep.iterations < o.max_iterations) {
    ++rep.iterations;
    double ratio = -1.0, new_cost = cost;
    if (SolveDamped(ne, radius, factorisation, step)) {
      const double model = ModelDecrease(ne, step);
      trial = state;
      ApplyStep(L, step, trial);
      new_cost = Cost(problem, trial, b, nullptr);
      if (model > 0 && std::isfinite(new_cost)) ratio = (cost - new_cost) / model;
    }
    if (ratio <= 1e-3) {
      radius /= nu;
      nu *= 2.0;
      if (radius < 1e-32) {
        rep.converged = true;
        rep.message = "no further decrease (damping radius below 1e-32)";
      }
      continue;
    }
    const double step_norm = std::sqrt(step.points.squaredNorm() + step.global.squaredNorm());
    const double x_norm = ParameterNorm(L, state);
    std::swap(state, trial);
    const double decrease = cost - new_cost;
    cost = wp ? Cost(problem, state, b, wp) : new_cost;
    selfcal_normal::Build(problem, L, state, wp, ne);
    radius = std::min(1e16, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * ratio - 1.0, 3)));
    nu = 2.0;
    if (decrease <= o.function_tolerance * (cost + decrease)) {
      rep.converged = true;
      rep.message = "function tolerance reached";
    } else if (step_norm <= o.parameter_tolerance * (x_norm + o.parameter_tolerance)) {
      rep.converged = true;
      rep.message = "parameter tolerance reached";
    } else if (GradientMax(ne) <= o.gradient_tolerance) {
      rep.converged = true;
      rep.message = "gradient below tolerance";
    }
  }
  rep.final_cost = cost;
  return rep;
}

}  // namespace

void SolveOptions::Check() const {
  KM_OPTION_GE(cauchy_scale_um, 0.0);
  KM_OPTION_GE(max_iterations, 1);
  KM_OPTION_GT(initial_trust_region_radius, 0.0);
  KM_OPTION_GT(function_tolerance, 0.0);
  KM_OPTION_GT(gradient_tolerance, 0.0);
  KM_OPTION_GT(parameter_tolerance, 0.0);
}

SolveReport SolveSelfCal(const SelfCalProblem& problem, const SolveOptions& options,
                         SelfCalState& state) {
  options.Check();
  problem.UpdateZeroLengths(state);
  Gauge gauge;
  gauge.on_points = PickGaugePoints(problem, state, gauge.points);
  if (gauge.on_points) Apply(PointFrame(state, gauge.points), state);
  const ColumnLayout layout = selfcal_normal::MakeLayout(problem, gauge);
  SolveReport rep = Minimise(problem, options, layout, state);
  // Back to the gauge of docs/formats.md §3: tracker 1 at the origin, 2 on +x, 3 in the xy-plane,
  // z of 4 > 0.
  if (gauge.on_points) {
    Apply(GaugeTransform(state.trackers_mm), state);
    state.trackers_mm[0].setZero();
    state.trackers_mm[1].tail<2>().setZero();
    state.trackers_mm[2].z() = 0.0;
  }
  problem.UpdateZeroLengths(state);
  return rep;
}

}  // namespace km::tracker
