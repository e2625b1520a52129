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

using Row = Eigen::Map<Eigen::RowVectorXd>;
using ConstRow = Eigen::Map<const Eigen::RowVectorXd>;

// The damped point block of eliminated point e.
Eigen::Matrix3d Damped(const NormalEquations& ne, std::size_t e, double radius) {
  Eigen::Matrix3d Ad = ne.A[e];
  for (int a = 0; a < 3; ++a) Ad(a, a) += Scaling(Ad(a, a)) / radius;
  return Ad;
}

// L with L·Lᵀ = A (3×3, written out: it runs once a point and step); false unless A is
// positive definite.
bool Cholesky3(const Eigen::Matrix3d& A, Eigen::Matrix3d& L) {
  L.setZero();
  const double d0 = A(0, 0);
  if (!(d0 > 0)) return false;
  L(0, 0) = std::sqrt(d0);
  L(1, 0) = A(1, 0) / L(0, 0);
  L(2, 0) = A(2, 0) / L(0, 0);
  const double d1 = A(1, 1) - L(1, 0) * L(1, 0);
  if (!(d1 > 0)) return false;
  L(1, 1) = std::sqrt(d1);
  L(2, 1) = (A(2, 1) - L(2, 0) * L(1, 0)) / L(1, 1);
  const double d2 = A(2, 2) - L(2, 0) * L(2, 0) - L(2, 1) * L(2, 1);
  if (!(d2 > 0)) return false;
  L(2, 2) = std::sqrt(d2);
  return true;
}

bool Factorise(const NormalEquations& ne, double radius, Factorisation& f) {
  const auto ne_count = static_cast<Eigen::Index>(ne.A.size());
  const Eigen::Index c = ne.F.rows();
  f.radius = radius;
  f.L.resize(ne.A.size());
  f.W.resize(3 * ne_count, c);
  for (Eigen::Index e = 0; e < ne_count; ++e) {
    Eigen::Matrix3d& L = f.L[static_cast<std::size_t>(e)];
    if (!Cholesky3(Damped(ne, static_cast<std::size_t>(e), radius), L)) return false;
    // W_e = L⁻¹E_e, row by row (forward substitution on the rows of E_e).
    ConstRow e0(ne.E.data() + 3 * e * c, c), e1(e0.data() + c, c), e2(e0.data() + 2 * c, c);
    Row w0(f.W.data() + 3 * e * c, c), w1(w0.data() + c, c), w2(w0.data() + 2 * c, c);
    w0 = e0 / L(0, 0);
    w1 = (e1 - L(1, 0) * w0) / L(1, 1);
    w2 = (e2 - L(2, 0) * w0 - L(2, 1) * w1) / L(2, 2);
  }
  Eigen::MatrixXd S = ne.F;
  for (Eigen::Index a = 0; a < c; ++a) S(a, a) += Scaling(S(a, a)) / radius;
  S.selfadjointView<Eigen::Lower>().rankUpdate(f.W.transpose(), -1.0);
  f.reduced.compute(S.selfadjointView<Eigen::Lower>());
  return f.reduced.info() == Eigen::Success;
}

// δ with (JᵀJ + D/radius)·δ = −g: w_e = L_e⁻¹g_e, the reduced system
// (F − WᵀW)·δ_c = −(g_c − Wᵀw), then δ_e = −L_e⁻ᵀ(w_e + W_e δ_c). Two passes over W.
void Solve(const Factorisation& f, const Eigen::VectorXd& g_points, const Eigen::VectorXd& g,
           Step& step) {
  const auto ne_count = static_cast<Eigen::Index>(f.L.size());
  const Eigen::Index c = f.W.cols();
  Eigen::VectorXd w(3 * ne_count);
  Eigen::RowVectorXd Wtw = Eigen::RowVectorXd::Zero(c);
  for (Eigen::Index e = 0; e < ne_count; ++e) {
    const Eigen::Matrix3d& L = f.L[static_cast<std::size_t>(e)];
    const auto ge = g_points.segment<3>(3 * e);
    const double x0 = ge(0) / L(0, 0);
    const double x1 = (ge(1) - L(1, 0) * x0) / L(1, 1);
    const double x2 = (ge(2) - L(2, 0) * x0 - L(2, 1) * x1) / L(2, 2);
    w.segment<3>(3 * e) << x0, x1, x2;
    ConstRow w0(f.W.data() + 3 * e * c, c), w1(w0.data() + c, c), w2(w0.data() + 2 * c, c);
    Wtw += x0 * w0 + x1 * w1 + x2 * w2;
  }
  step.global = -f.reduced.solve(g - Wtw.transpose());
  step.points.resize(3 * ne_count);
  for (Eigen::Index e = 0; e < ne_count; ++e) {
    const Eigen::Matrix3d& L = f.L[static_cast<std::size_t>(e)];
    ConstRow w0(f.W.data() + 3 * e * c, c), w1(w0.data() + c, c), w2(w0.data() + 2 * c, c);
    const double b0 = w(3 * e) + w0.dot(step.global.transpose());
    const double b1 = w(3 * e + 1) + w1.dot(step.global.transpose());
    const double b2 = w(3 * e + 2) + w2.dot(step.global.transpose());
    // δ_e = −L⁻ᵀb (back substitution).
    const double y2 = b2 / L(2, 2);
    const double y1 = (b1 - L(2, 1) * y2) / L(1, 1);
    const double y0 = (b0 - L(1, 0) * y1 - L(2, 0) * y2) / L(0, 0);
    step.points.segment<3>(3 * e) << -y0, -y1, -y2;
  }
}

// (JᵀJ + D/radius)·δ from the blocks (sums of the rows: exact where F − WᵀW cancels), in one
// pass over E.
Step Product(const NormalEquations& ne, double radius, const Step& d) {
  const auto ne_count = static_cast<Eigen::Index>(ne.A.size());
  const Eigen::Index c = ne.F.cols();
  Step out;
  out.points.resize(3 * ne_count);
  Eigen::RowVectorXd Etd = Eigen::RowVectorXd::Zero(c);
  for (Eigen::Index e = 0; e < ne_count; ++e) {
    const auto de = d.points.segment<3>(3 * e);
    out.points.segment<3>(3 * e) = Damped(ne, static_cast<std::size_t>(e), radius) * de;
    for (int a = 0; a < 3; ++a) {
      ConstRow row(ne.E.data() + (3 * e + a) * c, c);
      out.points(3 * e + a) += row.dot(d.global.transpose());
      Etd += de(a) * row;
    }
  }
  out.global = ne.F * d.global + Etd.transpose();
  for (Eigen::Index a = 0; a < c; ++a) {
    out.global(a) += Scaling(ne.F(a, a)) / radius * d.global(a);
  }
  return out;
}

// The damped step, with one round of iterative refinement: with far trackers F − WᵀW loses
// digits to cancellation, and the step along the weakly determined directions with them.
bool SolveDamped(const NormalEquations& ne, double radius, bool refine, Factorisation& f,
                 Step& step) {
  if (!Factorise(ne, radius, f)) return false;
  Solve(f, ne.g_points, ne.g, step);
  if (!refine) return step.points.allFinite() && step.global.allFinite();
  const Step hd = Product(ne, radius, step);
  Step correction;
  Solve(f, ne.g_points + hd.points, ne.g + hd.global, correction);
  step.points += correction.points;
  step.global += correction.global;
  return step.points.allFinite() && step.global.allFinite();
}

// Decrease of the quadratic model, −(gᵀδ + ½ δᵀJᵀJδ): with (JᵀJ + D/radius)·δ = −g (the refined
// step) it is ½(−gᵀδ + δᵀDδ/radius).
double ModelDecrease(const NormalEquations& ne, double radius, const Step& step) {
  double dd = 0;
  for (std::size_t e = 0; e < ne.A.size(); ++e) {
    for (int a = 0; a < 3; ++a) {
      const double x = step.points(3 * static_cast<Eigen::Index>(e) + a);
      dd += Scaling(ne.A[e](a, a)) * x * x;
    }
  }
  for (Eigen::Index a = 0; a < step.global.size(); ++a) {
    dd += Scaling(ne.F(a, a)) * step.global(a) * step.global(a);
  }
  return 0.5 * (-ne.g.dot(step.global) - ne.g_points.dot(step.points) + dd / radius);
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

// The largest coordinate of the unknowns (mm).
double ParameterMax(const ColumnLayout& L, const SelfCalState& s) {
  double x = 0;
  for (int p : L.eliminated_point) {
    x = std::max(x, s.points_mm[static_cast<std::size_t>(p)].lpNorm<Eigen::Infinity>());
  }
  for (const auto& u : s.trackers_mm) x = std::max(x, u.lpNorm<Eigen::Infinity>());
  for (std::size_t q = 0; q < L.offset_column.size(); ++q) {
    if (L.offset_column[q] >= 0) x = std::max(x, std::abs(s.offsets_mm[q]));
  }
  return x;
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
  std::vector<double> weights, trial_weights;
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
    double ratio = -1.0, new_cost = cost, model = 0.0;
    // Steps, not the cost, tell convergence along the weakly determined directions (far
    // trackers): there a step of 0.1 µm changes the cost by less than its rounding.
    bool small_step = false;
    if (SolveDamped(ne, radius, o.refine_steps, factorisation, step)) {
      model = ModelDecrease(ne, radius, step);
      const double step_max =
          std::max(step.points.lpNorm<Eigen::Infinity>(), step.global.lpNorm<Eigen::Infinity>());
      small_step =
          step_max <= o.parameter_tolerance * (ParameterMax(L, state) + o.parameter_tolerance);
      trial = state;
      ApplyStep(L, step, trial);
      new_cost = Cost(problem, trial, b, wp ? &trial_weights : nullptr);
      if (model > 0 && std::isfinite(new_cost)) ratio = (cost - new_cost) / model;
    }
    // At the optimum the model promises less than the rounding of the cost: no step could be
    // told successful.
    if (model >= 0 && model <= o.function_tolerance * cost && radius >= 1e4) {
      if (ratio > 0) std::swap(state, trial);
      if (ratio > 0 && b == 0) cost = new_cost;
      rep.converged = true;
      rep.message = "predicted decrease below the function tolerance (the rounding of the cost)";
      break;
    }
    if (ratio <= 1e-3) {
      radius /= nu;
      nu *= 2.0;
      if (small_step) {
        rep.converged = true;
        rep.message = "parameter tolerance reached (no decrease left)";
      } else if (radius < 1e-32) {
        rep.converged = true;
        rep.message = "no further decrease (damping radius below 1e-32)";
      }
      continue;
    }
    std::swap(state, trial);
    std::swap(weights, trial_weights);
    cost = new_cost;
    selfcal_normal::Build(problem, L, state, wp, ne);
    radius = std::min(1e16, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * ratio - 1.0, 3)));
    nu = 2.0;
    if (small_step) {
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
