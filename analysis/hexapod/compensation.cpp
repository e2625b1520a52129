#include "analysis/hexapod/compensation.h"

#include <cmath>
#include <cstddef>
#include <numbers>

#include <Eigen/Core>

#include "analysis/core/errors.h"
#include "analysis/hexapod/dbb_geometry.h"

namespace km::hexapod {
namespace {

// Change of every sample of test t (µm on the bar) caused by `effects`, to first order.
std::vector<double> EffectsOnBar(const EffectFitData& d, const EffectFitResult& fit,
                                 const std::vector<ActiveEffect>& effects, std::size_t t) {
  Perturbation pert;
  ApplyEffects(effects, d.prepared.paths[t], d.prepared.setup, pert);
  std::vector<double> out;
  for (std::size_t i = 0; i < pert.ds_mm.size(); ++i) {
    RowSensitivity delta;
    delta.head<6>() = pert.ds_mm[i];
    delta[6] = pert.dl_mm[i];
    out.push_back(fit.sensitivity[static_cast<std::size_t>(d.row_begin[t]) + i].dot(delta));
  }
  return out;
}

// The measured trace of test t and the two predicted ones, each on the bar (µm) at the angle of
// the tool about its fixed ball (degrees, one turn unwrapped).
struct Traces {
  std::vector<double> angle_deg, measured, without, with;
};

Traces TracesOfTest(const EffectFitData& d, const EffectFitResult& fit,
                    const std::vector<ActiveEffect>& comp, std::size_t t) {
  const auto& test = d.problem.tests[t];
  const auto all = EffectsOnBar(d, fit, fit.effects, t);
  const auto compensated = EffectsOnBar(d, fit, comp, t);
  const auto& path = d.prepared.paths[t];
  const double bar0 = test.samples.front().measured_bar_mm;
  Traces tr;
  for (std::size_t i = 0; i < test.samples.size(); ++i) {
    const int row = d.row_begin[t] + static_cast<int>(i);
    const Eigen::Vector3d v = path.pose[i].tip_mm - fit.fixed_balls_mm[t];
    tr.angle_deg.push_back(std::atan2(v.y(), v.x()) * 180.0 / std::numbers::pi);
    tr.measured.push_back(1000.0 * (test.samples[i].measured_bar_mm - bar0));
    const double residual = -fit.residual_um[row];  // measured − model
    tr.without.push_back(residual + all[i]);
    tr.with.push_back(residual + all[i] - compensated[i]);
  }
  auto& a = tr.angle_deg;
  for (std::size_t i = 1; i < a.size(); ++i) {  // one turn, unwrapped
    while (a[i] - a[i - 1] > 180.0) a[i] -= 360.0;
    while (a[i] - a[i - 1] < -180.0) a[i] += 360.0;
  }
  return tr;
}

}  // namespace

std::optional<CompensationPreview> PreviewCompensation(const EffectFitData& d,
                                                       const EffectFitResult& fit) {
  std::vector<ActiveEffect> comp;
  CompensationPreview out;
  for (const auto& a : fit.effects) {
    const std::string n = a.effect->Name();
    if (n == "gravity_deflection" || n == "joint_friction") {
      comp.push_back(a);
      out.compensated_effects.push_back(n);
    }
  }
  if (comp.empty()) return std::nullopt;
  for (std::size_t t = 0; t < d.problem.tests.size(); ++t) {
    const auto& test = d.problem.tests[t];
    const Traces tr = TracesOfTest(d, fit, comp, t);
    const double bar0 = test.samples.front().measured_bar_mm;
    try {
      out.tests.push_back({test.test_id, test.direction,
                           TraceCircleFigures(tr.angle_deg, tr.measured, bar0).circularity_um,
                           TraceCircleFigures(tr.angle_deg, tr.without, bar0).circularity_um,
                           TraceCircleFigures(tr.angle_deg, tr.with, bar0).circularity_um});
    } catch (const Error&) {
      continue;  // no circle through the trace (fewer than 3 distinct samples): no figures
    }
  }
  return out;
}

}  // namespace km::hexapod
