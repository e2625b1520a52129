#include "analysis/hexapod/effect_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"
#include "analysis/core/parallel.h"

namespace km::hexapod {
namespace {

// Where every free parameter of a fit lives.
struct Layout {
  std::vector<int> k;                       // free kinematic indices
  std::vector<std::pair<int, int>> effect;  // (effect, parameter) of free effect parameters
  std::vector<std::pair<int, int>> ball;    // (test, coordinate) of estimated ball coordinates
  int size() const { return static_cast<int>(k.size() + effect.size() + ball.size()); }
};

Layout LayoutOf(const EffectFitData& d, const EffectFitResult& s) {
  Layout l;
  for (int i = 0; i < kNumKinematicParameters; ++i)
    if (!d.problem.fixed[static_cast<std::size_t>(i)]) l.k.push_back(i);
  for (std::size_t e = 0; e < s.effects.size(); ++e)
    for (std::size_t p = 0; p < s.effects[e].params.size(); ++p)
      if (s.effects[e].params[p].free) l.effect.emplace_back(e, p);
  for (std::size_t t = 0; t < d.problem.tests.size(); ++t) {
    const auto& test = d.problem.tests[t];
    if (test.fixed_ball_known) continue;
    for (int c = 0; c < 3; ++c)
      if (c != test.ball_fixed_axis) l.ball.emplace_back(static_cast<int>(t), c);
  }
  return l;
}

Eigen::VectorXd Pack(const Layout& l, const EffectFitResult& s) {
  Eigen::VectorXd x(l.size());
  int i = 0;
  for (int k : l.k) x[i++] = s.k_um[k];
  for (auto [e, p] : l.effect) x[i++] = s.effects[e].params[p].value;
  for (auto [t, c] : l.ball) x[i++] = s.fixed_balls_mm[t][c];
  return x;
}

void Unpack(const Layout& l, const Eigen::VectorXd& x, EffectFitResult& s) {
  int i = 0;
  for (int k : l.k) s.k_um[k] = x[i++];
  for (auto [e, p] : l.effect) {
    auto& par = s.effects[e].params[p];
    par.value = std::clamp(x[i++], par.lower, par.upper);
  }
  for (auto [t, c] : l.ball) s.fixed_balls_mm[t][c] = x[i++];
}

// Residuals of the model `s`; with `jac`, also the Jacobian (columns of the layout) and the
// row sensitivities.
struct Evaluation {
  Eigen::VectorXd r;
  Eigen::MatrixXd jac;
  std::vector<RowSensitivity> sens;
  bool ok = true;
};

// Residuals, and with a layout the Jacobian rows and sensitivities, of test t (rows disjoint
// from every other test's). False when the forward kinematics fails.
bool EvaluateTest(const EffectFitData& d, const EffectFitResult& s, const Layout* layout,
                  const HexapodGeometry& g, std::size_t t, Evaluation& ev) {
  const auto& test = d.problem.tests[t];
  const PreparedTests& pt = s.statics ? *s.statics : d.prepared;
  Perturbation pert;
  ApplyEffects(s.effects, pt.paths[t], pt.setup, pert);
  const Eigen::Vector3d& F = s.fixed_balls_mm[t];
  for (std::size_t i = 0; i < test.samples.size(); ++i) {
    const int row = d.row_begin[t] + static_cast<int>(i);
    const auto& sample = test.samples[i];
    const double l = test.tool_length_mm + pert.dl_mm[i];
    ForwardResult fk;
    try {
      fk = ForwardKinematics(g, sample.strut_command_mm + pert.ds_mm[i], l, sample.commanded);
    } catch (const DidNotConverge&) {
      return false;
    }
    const Eigen::Vector3d v = fk.pose.tip_mm - F;
    const double bar = v.norm();
    ev.r[row] = 1000.0 * (bar - sample.measured_bar_mm);
    if (!layout) continue;
    const Eigen::Vector3d e = v / bar;
    Vector6d rhs = Vector6d::Zero();
    rhs.head<3>() = e;
    const Vector6d w = fk.jacobian.transpose().partialPivLu().solve(rhs);
    RowSensitivity sv;
    sv.head<6>() = 1000.0 * w;
    sv[6] = -1000.0 * e.dot(RotationABC(fk.pose.abc_rad).col(2));
    ev.sens[static_cast<std::size_t>(row)] = sv;
    int c = 0;
    for (int k : layout->k)
      ev.jac(row, c++) = k < 6 ? w[k] : w[(k - 6) / 3] * fk.jacobian((k - 6) / 3, (k - 6) % 3);
    c += static_cast<int>(layout->effect.size());  // filled by EffectColumns
    for (auto [bt, bc] : layout->ball) {
      if (bt == static_cast<int>(t)) ev.jac(row, c) = -1000.0 * e[bc];
      ++c;
    }
  }
  return true;
}

// Effect parameter columns of test t: central differences of the effect models, mapped through
// the row sensitivities.
void EffectColumns(const EffectFitData& d, const EffectFitResult& s, const Layout& layout,
                   std::size_t t, Evaluation& ev) {
  const int c0 = static_cast<int>(layout.k.size());
  const PreparedTests& pt = s.statics ? *s.statics : d.prepared;
  Perturbation pp, pm;
  for (std::size_t q = 0; q < layout.effect.size(); ++q) {
    const auto [e, p] = layout.effect[q];
    const auto& par = s.effects[e].params[p];
    const double h = 1e-3 * std::max(std::abs(par.value), par.scale);
    auto plus = s.effects, minus = s.effects;
    plus[e].params[p].value += h;
    minus[e].params[p].value -= h;
    ApplyEffects(plus, pt.paths[t], pt.setup, pp);
    ApplyEffects(minus, pt.paths[t], pt.setup, pm);
    for (std::size_t i = 0; i < pp.ds_mm.size(); ++i) {
      const int row = d.row_begin[t] + static_cast<int>(i);
      RowSensitivity delta;
      delta.head<6>() = pp.ds_mm[i] - pm.ds_mm[i];
      delta[6] = pp.dl_mm[i] - pm.dl_mm[i];
      ev.jac(row, c0 + static_cast<int>(q)) =
          ev.sens[static_cast<std::size_t>(row)].dot(delta) / (2.0 * h);
    }
  }
}

// The tests are independent: evaluated in parallel, each writing its own rows.
Evaluation Evaluate(const EffectFitData& d, const EffectFitResult& s, const Layout* layout) {
  const int n = d.rows();
  Evaluation ev;
  ev.r.resize(n);
  if (layout) {
    ev.jac = Eigen::MatrixXd::Zero(n, layout->size());
    ev.sens.resize(static_cast<std::size_t>(n));
  }
  const HexapodGeometry g = ApplyParameters(d.problem.nominal, s.k_um);
  const std::size_t tests = d.problem.tests.size();
  std::vector<char> ok(tests, 1);
  ParallelFor(tests, [&](std::size_t t) {
    ok[t] = EvaluateTest(d, s, layout, g, t, ev) ? 1 : 0;
    if (ok[t] && layout) EffectColumns(d, s, *layout, t, ev);
  });
  ev.ok = std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; });
  return ev;
}

std::vector<std::string> ColumnNames(const Layout& l, const EffectFitResult& s,
                                     const EffectFitData& d, std::vector<int>* test_of) {
  std::vector<std::string> names;
  for (int k : l.k) {
    names.push_back(ParameterName(k));
    test_of->push_back(-1);
  }
  for (auto [e, p] : l.effect) {
    names.push_back(std::string(s.effects[e].effect->Name()) + "." + s.effects[e].params[p].name);
    test_of->push_back(-1);
  }
  for (auto [t, c] : l.ball) {
    names.push_back(d.problem.tests[t].test_id + ".fixed_ball_mm[" + std::to_string(c) + "]");
    test_of->push_back(t);
  }
  return names;
}

// Cluster (test_id) of every residual row.
std::vector<int> RowClusters(const EffectFitData& d, int* count) {
  std::map<std::string, int> ids;
  std::vector<int> rows(static_cast<std::size_t>(d.rows()), 0);
  for (std::size_t t = 0; t < d.problem.tests.size(); ++t) {
    const int c =
        ids.emplace(d.problem.tests[t].test_id, static_cast<int>(ids.size())).first->second;
    for (int r = d.row_begin[t]; r < d.row_begin[t + 1]; ++r) rows[static_cast<std::size_t>(r)] = c;
  }
  *count = static_cast<int>(ids.size());
  return rows;
}

// Which free parameters sit on a bound (effect parameters only).
std::vector<bool> AtBound(const Layout& l, const EffectFitResult& s) {
  std::vector<bool> held(static_cast<std::size_t>(l.size()), false);
  for (std::size_t q = 0; q < l.effect.size(); ++q) {
    const auto [e, p] = l.effect[q];
    const auto& par = s.effects[e].params[p];
    const double tol = 1e-9 * std::max(1.0, std::abs(par.value)) + 1e-12 * par.scale;
    held[l.k.size() + q] = par.value <= par.lower + tol || par.value >= par.upper - tol;
  }
  return held;
}

// Test-level (delete-one-cluster jackknife, CR3) variance of the parameters of the linearised
// problem J·δ = r: the change of the solution when the rows of one cluster are left out,
// d_g = (JᵀJ − J_gᵀJ_g)⁻¹ J_gᵀ r_g, and V = (G − 1)/G · Σ_g (d_g − d̄)(d_g − d̄)ᵀ. Columns
// local to the left-out cluster (a test's fixed-ball position) are held at their value. It
// holds for residuals correlated within a test and is not optimistic with few clusters.
Eigen::VectorXd JackknifeVariance(const Eigen::MatrixXd& j, const Eigen::VectorXd& r,
                                  const std::vector<int>& row_cluster, int clusters,
                                  const std::vector<int>& local_cluster) {
  const int m = static_cast<int>(j.cols()), n = static_cast<int>(j.rows());
  std::vector<Eigen::MatrixXd> gram(static_cast<std::size_t>(clusters),
                                    Eigen::MatrixXd::Zero(m, m));
  Eigen::MatrixXd scores = Eigen::MatrixXd::Zero(m, clusters);
  for (int row = 0; row < n; ++row) {
    const int g = row_cluster[static_cast<std::size_t>(row)];
    gram[static_cast<std::size_t>(g)].selfadjointView<Eigen::Lower>().rankUpdate(
        j.row(row).transpose());
    scores.col(g) += j.row(row).transpose() * r[row];
  }
  Eigen::MatrixXd all = Eigen::MatrixXd::Zero(m, m);
  for (auto& a : gram) {
    a = a.selfadjointView<Eigen::Lower>();
    all += a;
  }
  Eigen::MatrixXd d(m, clusters);
  for (int g = 0; g < clusters; ++g) {
    Eigen::MatrixXd rest = all - gram[static_cast<std::size_t>(g)];
    for (int c = 0; c < m; ++c)
      if (local_cluster[static_cast<std::size_t>(c)] == g) rest(c, c) += 1.0;
    d.col(g) = rest.ldlt().solve(scores.col(g));
  }
  const Eigen::VectorXd mean = d.rowwise().mean();
  const Eigen::MatrixXd dev = d.colwise() - mean;
  return (static_cast<double>(clusters - 1) / clusters) * dev.rowwise().squaredNorm();
}

// Covariance, uncertainties and statistics at the solution. Parameters on a bound are held
// there; the σ of the others is the larger of the white-residual and the cluster-robust one.
void FillStatistics(const Layout& l, const Evaluation& ev, const std::vector<int>& row_cluster,
                    int clusters, const std::vector<int>& rows_of_test, EffectFitResult& s) {
  const int n = static_cast<int>(ev.r.size()), p = l.size();
  s.residual_um = ev.r;
  s.rss_um2 = ev.r.squaredNorm();
  s.dof = std::max(1, n - p);
  s.residual_rms_um = n > 0 ? std::sqrt(s.rss_um2 / n) : 0.0;
  s.jacobian = ev.jac;
  s.sensitivity = ev.sens;
  s.clusters = clusters;
  s.k_sigma_um.setZero();
  s.effect_sigma.assign(s.effects.size(), {});
  s.effect_at_bound.assign(s.effects.size(), {});
  s.held_inputs.clear();
  for (std::size_t e = 0; e < s.effects.size(); ++e) {
    s.effect_sigma[e].assign(s.effects[e].params.size(), 0.0);
    s.effect_at_bound[e].assign(s.effects[e].params.size(), false);
  }
  s.effect_sigma_statistical = s.effect_sigma;
  if (p == 0) return;
  const std::vector<bool> held = AtBound(l, s);
  std::vector<int> cols;
  for (int i = 0; i < p; ++i)
    if (!held[static_cast<std::size_t>(i)]) cols.push_back(i);
  const int m = static_cast<int>(cols.size());
  // Column scaling keeps the condition number meaningful across units.
  Eigen::MatrixXd js(n, m);
  Eigen::VectorXd scale(m);
  for (int c = 0; c < m; ++c) {
    const double norm = ev.jac.col(cols[c]).norm();
    scale[c] = norm > 0.0 ? norm : 1.0;
    js.col(c) = ev.jac.col(cols[c]) / scale[c];
  }
  Eigen::VectorXd var = Eigen::VectorXd::Zero(m);
  if (m > 0) {
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(js);
    const auto& sv = svd.singularValues();
    s.condition_number = sv[sv.size() - 1] > 0.0 ? sv[0] / sv[sv.size() - 1] : 1e300;
    const Eigen::MatrixXd bread =
        (js.transpose() * js).ldlt().solve(Eigen::MatrixXd::Identity(m, m));
    var = (s.rss_um2 / std::max(1, n - m)) * bread.diagonal();
    if (clusters >= 4) {
      std::vector<int> local_cluster(static_cast<std::size_t>(m), -1);
      for (int c = 0; c < m; ++c) {
        const int q = cols[c] - static_cast<int>(l.k.size() + l.effect.size());
        if (q >= 0) {
          const int t = l.ball[static_cast<std::size_t>(q)].first;
          local_cluster[static_cast<std::size_t>(c)] =
              row_cluster[static_cast<std::size_t>(rows_of_test[static_cast<std::size_t>(t)])];
        }
      }
      var = var.cwiseMax(JackknifeVariance(js, ev.r, row_cluster, clusters, local_cluster));
    }
  }
  std::vector<double> sigma(static_cast<std::size_t>(p), std::nan(""));
  for (int c = 0; c < m; ++c)
    sigma[static_cast<std::size_t>(cols[c])] = std::sqrt(std::max(0.0, var[c])) / scale[c];
  int i = 0;
  for (int k : l.k) s.k_sigma_um[k] = sigma[static_cast<std::size_t>(i++)];
  for (auto [e, q] : l.effect) {
    s.effect_sigma[e][q] = sigma[static_cast<std::size_t>(i)];
    s.effect_at_bound[e][q] = held[static_cast<std::size_t>(i)];
    ++i;
  }
  s.effect_sigma_statistical = s.effect_sigma;
}

// Decrease of the cost that the linearised model predicts for a Gauss–Newton step, with the
// parameters on a bound whose gradient pushes outward held.
double PredictedDecrease(const Layout& l, const Evaluation& ev, const EffectFitResult& s) {
  const Eigen::VectorXd g = ev.jac.transpose() * ev.r;
  const std::vector<bool> held = AtBound(l, s);
  std::vector<int> cols;
  for (int i = 0; i < l.size(); ++i)
    if (!held[static_cast<std::size_t>(i)]) cols.push_back(i);
  if (cols.empty()) return 0.0;
  Eigen::MatrixXd j(ev.jac.rows(), static_cast<int>(cols.size()));
  Eigen::VectorXd gr(static_cast<int>(cols.size()));
  for (std::size_t c = 0; c < cols.size(); ++c) {
    j.col(static_cast<int>(c)) = ev.jac.col(cols[c]);
    gr[static_cast<int>(c)] = g[cols[c]];
  }
  const Eigen::MatrixXd jtj = j.transpose() * j;
  const Eigen::VectorXd step = jtj.completeOrthogonalDecomposition().solve(-gr);
  return std::max(0.0, -gr.dot(step));
}

}  // namespace

EffectFitData PrepareEffectFit(const HexapodGeometry& nominal, const MachinePhysics* physics,
                               const std::vector<dbb::DbbTest>& tests,
                               const std::vector<std::optional<double>>& start_time_s,
                               CalibrationMethod method, int max_samples_per_test) {
  std::vector<dbb::DbbTest> thin = tests;
  if (max_samples_per_test > 0) {
    for (auto& t : thin) {
      const std::size_t n = t.angle_deg.size(), m = static_cast<std::size_t>(max_samples_per_test);
      if (n <= m) continue;
      const std::size_t stride = (n + m - 1) / m;
      std::vector<double> a, r;
      for (std::size_t i = 0; i < n; i += stride) {
        a.push_back(t.angle_deg[i]);
        r.push_back(t.dr_um[i]);
      }
      t.angle_deg = std::move(a);
      t.dr_um = std::move(r);
    }
  }
  EffectFitData d;
  CalibrationOptions options;
  options.method = method;
  d.problem = BuildCalibrationProblem(nominal, thin, options);
  AnalyzeObservability(d.problem);
  d.prepared = PrepareTests(nominal, physics, thin, start_time_s);
  d.row_begin.push_back(0);
  for (const auto& t : d.problem.tests)
    d.row_begin.push_back(d.row_begin.back() + static_cast<int>(t.samples.size()));
  return d;
}

EffectFitResult StartingPoint(const EffectFitData& data,
                              const std::vector<const HexapodEffect*>& effects) {
  EffectFitResult s;
  for (const auto* e : effects) {
    ActiveEffect a{e, e->Parameters(data.prepared.setup)};
    if (a.params.empty()) {
      throw NotObservable(std::string(e->Name()) +
                          " cannot be modelled for these tests (the machine file or the test "
                          "files lack what it needs)");
    }
    s.effects.push_back(std::move(a));
  }
  for (const auto& t : data.problem.tests) s.fixed_balls_mm.push_back(t.fixed_ball_mm);
  return s;
}

namespace {

// `r` with the tests' statics on the geometry of its kinematic parameters.
EffectFitResult WithStatics(const EffectFitData& data, const EffectFitResult& r) {
  EffectFitResult out = r;
  auto statics = std::make_shared<PreparedTests>(data.prepared);
  RefreshStatics(*statics, ApplyParameters(data.problem.nominal, r.k_um));
  out.statics = std::move(statics);
  return out;
}

EffectFitResult FitOnce(const EffectFitData& data, const EffectFitResult& start,
                        const EffectFitOptions& options) {
  EffectFitResult s = start;
  s.converged = false;
  if (s.fixed_balls_mm.size() != data.problem.tests.size()) {
    s.fixed_balls_mm.clear();
    for (const auto& t : data.problem.tests) s.fixed_balls_mm.push_back(t.fixed_ball_mm);
  }
  const Layout layout = LayoutOf(data, s);
  Evaluation ev = Evaluate(data, s, &layout);
  if (!ev.ok) throw DidNotConverge("forward kinematics failed at the starting point of the fit");
  double cost = ev.r.squaredNorm();
  double mu = 1e-6;
  s.stop_reason = "iteration limit";
  for (s.iterations = 0; s.iterations < options.max_iterations; ++s.iterations) {
    Eigen::MatrixXd jtj = ev.jac.transpose() * ev.jac;
    Eigen::VectorXd g = ev.jac.transpose() * ev.r;
    // A parameter on its bound that the descent would push further out is held this step.
    const std::vector<bool> bound = AtBound(layout, s);
    for (int i = 0; i < layout.size(); ++i) {
      if (!bound[static_cast<std::size_t>(i)]) continue;
      const auto [e, q] = layout.effect[static_cast<std::size_t>(i) - layout.k.size()];
      const auto& par = s.effects[e].params[q];
      const bool at_lower = par.value <= 0.5 * (par.lower + par.upper);
      if ((at_lower && g[i] > 0.0) || (!at_lower && g[i] < 0.0)) {
        jtj.row(i).setZero();
        jtj.col(i).setZero();
        jtj(i, i) = 1.0;
        g[i] = 0.0;
      }
    }
    bool improved = false;
    for (int tries = 0; tries < 12 && !improved; ++tries) {
      Eigen::MatrixXd a = jtj;
      a.diagonal() += mu * jtj.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd step = a.ldlt().solve(-g);
      EffectFitResult trial = s;
      Unpack(layout, Pack(layout, s) + step, trial);
      const Evaluation te = Evaluate(data, trial, nullptr);
      const double tc = te.ok ? te.r.squaredNorm() : HUGE_VAL;
      if (tc < cost) {
        const double rel = (cost - tc) / std::max(cost, 1e-300);
        s = std::move(trial);
        ev = Evaluate(data, s, &layout);
        cost = tc;
        mu = std::max(mu / 10.0, 1e-12);
        improved = true;
        s.converged = rel < options.relative_tolerance;
      } else {
        mu *= 10.0;
      }
    }
    if (s.converged) {
      s.stop_reason = "converged";
      break;
    }
    if (!improved) {
      // No damped step lowers the cost: a minimum when the linear model agrees, i.e. it
      // promises less than options.stall_tolerance of the cost (the RMS would change by half
      // that; finite-difference derivatives of the effects are not more accurate).
      const double predicted = PredictedDecrease(layout, ev, s);
      s.converged = predicted <= options.stall_tolerance * std::max(cost, 1e-300);
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "stalled: no step lowers the cost, though the linear model predicts a "
                    "decrease of %.3g um^2 of %.3g",
                    predicted, cost);
      s.stop_reason = s.converged ? "converged" : buf;
      break;
    }
  }
  int clusters = 0;
  const std::vector<int> row_cluster = RowClusters(data, &clusters);
  FillStatistics(layout, ev, row_cluster, clusters, data.row_begin, s);
  s.column_test.clear();
  s.column_name = ColumnNames(layout, s, data, &s.column_test);
  return s;
}

}  // namespace

void EffectFitOptions::Check() const {
  KM_OPTION_GE(max_iterations, 1);
  KM_OPTION_IN_OPEN(relative_tolerance, 0.0, 1.0);
  KM_OPTION_IN_OPEN(stall_tolerance, 0.0, 1.0);
}

EffectFitResult FitWithEffects(const EffectFitData& data, const EffectFitResult& start,
                               const EffectFitOptions& options) {
  options.Check();
  if (!data.prepared.setup.physics) return FitOnce(data, start, options);
  EffectFitResult s = FitOnce(data, WithStatics(data, start), options);
  if ((s.k_um - start.k_um).cwiseAbs().maxCoeff() > 10.0) {
    const int first = s.iterations;
    s = FitOnce(data, WithStatics(data, s), options);
    s.iterations += first;
  }
  PropagateHeldInputs(data, s);
  return s;
}

Eigen::VectorXd EffectContribution(const EffectFitData& data, const EffectFitResult& fit,
                                   const ActiveEffect& effect) {
  Eigen::VectorXd c(data.rows());
  std::vector<ActiveEffect> model = {effect};
  // The effect sees the model's compliance when it depends on it (joint friction).
  for (const auto& a : fit.effects)
    if (a.effect != effect.effect) model.insert(model.begin(), a);
  const PreparedTests& pt = fit.statics ? *fit.statics : data.prepared;
  ParallelFor(data.problem.tests.size(), [&](std::size_t t) {
    Perturbation pert, base;
    ApplyEffects(model, pt.paths[t], pt.setup, pert);
    ApplyEffects(fit.effects, pt.paths[t], pt.setup, base);
    for (std::size_t i = 0; i < pert.ds_mm.size(); ++i) {
      const int row = data.row_begin[t] + static_cast<int>(i);
      RowSensitivity delta;
      delta.head<6>() = pert.ds_mm[i] - base.ds_mm[i];
      delta[6] = pert.dl_mm[i] - base.dl_mm[i];
      c[row] = fit.sensitivity[static_cast<std::size_t>(row)].dot(delta);
    }
  });
  return c;
}

}  // namespace km::hexapod
