// The inputs a fit with effects holds at the machine file's values, propagated into the σ of
// what it fits (docs/methods.md §5). [PM-600 report] §4.2.5: K_stiff1 and K_stiff2 act on the
// DBB traces almost alike, so K_stiff1 is held at the ball screw's computed compliance and an
// error in it moves the fitted K_stiff2 (and a little the rest); the platform's mass and
// centre of gravity, held unless a variant fits them, scale and shift the strut loads alike.
// Each held input h with standard uncertainty u_h moves the refit, to first order, by
// δθ_h = −(JᵀJ)⁻¹Jᵀ (∂r/∂h)·u_h; σ² = σ²_statistical + Σ_h δθ_h².
#include <cmath>
#include <map>

#include <Eigen/Cholesky>

#include "analysis/core/parallel.h"
#include "analysis/hexapod/effect_fit.h"
#include "analysis/hexapod/effects/effect_list.h"

namespace km::hexapod {
namespace {

struct HeldChange {
  HeldInput input;
  int effect = -1;  // the effect whose held parameter it is; −1: K_stiff1 of the machine
  int param = -1;
};

std::vector<HeldChange> HeldChanges(const EffectFitResult& fit, const MachinePhysics& m) {
  std::vector<HeldChange> out;
  bool compliance = false;
  for (std::size_t e = 0; e < fit.effects.size(); ++e) {
    const HexapodEffect* eff = fit.effects[e].effect;
    if (eff == &GravityDeflectionEffect() || eff == &JointFrictionEffect()) compliance = true;
    if (eff != &GravityDeflectionEffect()) continue;
    for (std::size_t q = 0; q < fit.effects[e].params.size(); ++q) {
      const auto& par = fit.effects[e].params[q];
      if (par.free) continue;
      double u = 0.0;
      if (par.name == "platform_mass_kg") u = m.u_platform_mass_rel * std::abs(par.value);
      if (par.name.rfind("platform_cog_mm", 0) == 0) u = m.u_platform_cog_mm;
      if (u > 0.0)
        out.push_back(
            {{par.name, par.unit, par.value, u, {}}, static_cast<int>(e), static_cast<int>(q)});
    }
  }
  const double k1 = m.compliance_screw_mm_per_N;
  if (compliance && k1 != 0.0 && m.u_compliance_screw_rel > 0.0)
    out.insert(
        out.begin(),
        HeldChange{{"K_stiff1_mm_per_N", "mm/N", k1, m.u_compliance_screw_rel * std::abs(k1), {}},
                   -1,
                   -1});
  return out;
}

// Change of every residual row when the input moves by +u (central difference over ±u).
Eigen::VectorXd HeldColumn(const EffectFitData& d, const EffectFitResult& fit,
                           const HeldChange& h) {
  const PreparedTests& pt = fit.statics ? *fit.statics : d.prepared;
  MachinePhysics mp = *pt.setup.physics, mm = mp;
  auto plus = fit.effects, minus = fit.effects;
  if (h.effect < 0) {
    mp.compliance_screw_mm_per_N += h.input.u;
    mm.compliance_screw_mm_per_N -= h.input.u;
  } else {
    plus[static_cast<std::size_t>(h.effect)].params[static_cast<std::size_t>(h.param)].value +=
        h.input.u;
    minus[static_cast<std::size_t>(h.effect)].params[static_cast<std::size_t>(h.param)].value -=
        h.input.u;
  }
  EffectSetup sp = pt.setup, sm = pt.setup;
  sp.physics = &mp;
  sm.physics = &mm;
  Eigen::VectorXd c = Eigen::VectorXd::Zero(d.rows());
  ParallelFor(d.problem.tests.size(), [&](std::size_t t) {
    Perturbation pp, pm;
    ApplyEffects(plus, pt.paths[t], sp, pp);
    ApplyEffects(minus, pt.paths[t], sm, pm);
    for (std::size_t i = 0; i < pp.ds_mm.size(); ++i) {
      const int row = d.row_begin[t] + static_cast<int>(i);
      RowSensitivity delta;
      delta.head<6>() = pp.ds_mm[i] - pm.ds_mm[i];
      delta[6] = pp.dl_mm[i] - pm.dl_mm[i];
      c[row] = 0.5 * fit.sensitivity[static_cast<std::size_t>(row)].dot(delta);
    }
  });
  return c;
}

}  // namespace

void PropagateHeldInputs(const EffectFitData& data, EffectFitResult& fit) {
  fit.held_inputs.clear();
  const PreparedTests& pt = fit.statics ? *fit.statics : data.prepared;
  const int n = data.rows(), p = static_cast<int>(fit.jacobian.cols());
  if (!pt.setup.physics || !pt.setup.physics->has_gravity || fit.effects.empty() || p == 0 ||
      fit.jacobian.rows() != n || static_cast<int>(fit.sensitivity.size()) != n ||
      static_cast<int>(fit.column_name.size()) != p)
    return;
  const std::vector<HeldChange> changes = HeldChanges(fit, *pt.setup.physics);
  if (changes.empty()) return;
  // Columns of the fit: kinematic (−1, k), effect (e, q), fixed-ball (−2); on a bound: held.
  std::map<std::string, std::pair<int, int>> known;
  for (int k = 0; k < kNumKinematicParameters; ++k) known[ParameterName(k)] = {-1, k};
  for (std::size_t e = 0; e < fit.effects.size(); ++e)
    for (std::size_t q = 0; q < fit.effects[e].params.size(); ++q)
      known[std::string(fit.effects[e].effect->Name()) + "." + fit.effects[e].params[q].name] = {
          static_cast<int>(e), static_cast<int>(q)};
  std::vector<int> cols;
  std::vector<std::pair<int, int>> where;
  for (int c = 0; c < p; ++c) {
    const auto it = known.find(fit.column_name[static_cast<std::size_t>(c)]);
    const std::pair<int, int> w = it == known.end() ? std::pair<int, int>{-2, -1} : it->second;
    if (w.first >= 0 && !std::isfinite(fit.effect_sigma[static_cast<std::size_t>(w.first)]
                                                       [static_cast<std::size_t>(w.second)]))
      continue;
    cols.push_back(c);
    where.push_back(w);
  }
  const int m = static_cast<int>(cols.size());
  Eigen::MatrixXd js(n, m);
  Eigen::VectorXd scale(m);
  for (int c = 0; c < m; ++c) {
    const double norm = fit.jacobian.col(cols[static_cast<std::size_t>(c)]).norm();
    scale[c] = norm > 0.0 ? norm : 1.0;
    js.col(c) = fit.jacobian.col(cols[static_cast<std::size_t>(c)]) / scale[c];
  }
  const Eigen::LDLT<Eigen::MatrixXd> normal(js.transpose() * js);
  Eigen::VectorXd k_var = Eigen::VectorXd::Zero(kNumKinematicParameters);
  std::vector<std::vector<double>> e_var;
  for (const auto& a : fit.effects) e_var.emplace_back(a.params.size(), 0.0);
  for (const auto& h : changes) {
    HeldInput in = h.input;
    for (const auto& a : fit.effects) in.effect_shift.emplace_back(a.params.size(), 0.0);
    const Eigen::VectorXd shift =
        -normal.solve(js.transpose() * HeldColumn(data, fit, h)).cwiseQuotient(scale);
    for (int c = 0; c < m; ++c) {
      const auto [e, q] = where[static_cast<std::size_t>(c)];
      if (e == -1) k_var[q] += shift[c] * shift[c];
      if (e < 0) continue;
      in.effect_shift[static_cast<std::size_t>(e)][static_cast<std::size_t>(q)] = shift[c];
      e_var[static_cast<std::size_t>(e)][static_cast<std::size_t>(q)] += shift[c] * shift[c];
    }
    fit.held_inputs.push_back(std::move(in));
  }
  for (int k = 0; k < kNumKinematicParameters; ++k)
    fit.k_sigma_um[k] = std::sqrt(fit.k_sigma_um[k] * fit.k_sigma_um[k] + k_var[k]);
  for (std::size_t e = 0; e < fit.effects.size(); ++e)
    for (std::size_t q = 0; q < e_var[e].size(); ++q) {
      double& s = fit.effect_sigma[e][q];
      if (std::isfinite(s)) s = std::sqrt(s * s + e_var[e][q]);
    }
}

}  // namespace km::hexapod
