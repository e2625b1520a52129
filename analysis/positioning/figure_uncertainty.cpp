#include "analysis/positioning/figure_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <span>
#include <utility>

#include "analysis/core/errors.h"

namespace km::positioning {
namespace {

// What one draw needs: the raw per-target figures, each target's distance from the datum (µm),
// the corrections applied, and a work copy of the targets (allocated once).
struct DrawState {
  std::vector<TargetFigures> raw;
  std::vector<TargetFigures> work;
  std::vector<double> distance_um;
  std::optional<AirConditions> air;
  bool material = false;
};

// A drawn air condition beyond the range of the refractive-index equation (e.g. a humidity
// above 100 %) is taken at the edge of the range (docs/methods.md §16.3).
AirConditions DrawnAir(const AirConditions& stated, double t_c, double p_pa, double rh_pct) {
  AirConditions a = stated;
  a.temperature_c = std::clamp(t_c, 0.0, 100.0);
  a.pressure_pa = std::clamp(p_pa, 10000.0, 140000.0);
  a.humidity_pct = std::clamp(rh_pct, 0.0, 100.0);
  return a;
}

// The per-target figures of one draw: x̄' = (d + x̄)·c − d − m·d, s' = |c|·s, R_i' = |c|·R_i.
void TransformTargets(DrawState& st, double scale, double material_per_um) {
  const double abs_scale = std::abs(scale);
  for (std::size_t i = 0; i < st.raw.size(); ++i) {
    const TargetFigures& r = st.raw[i];
    TargetFigures& w = st.work[i];
    const double d = st.distance_um[i];
    w.mean_up_um = (d + r.mean_up_um) * scale - d - material_per_um * d;
    w.mean_down_um = (d + r.mean_down_um) * scale - d - material_per_um * d;
    w.s_up_um = abs_scale * r.s_up_um;
    w.s_down_um = abs_scale * r.s_down_um;
    w.reversal_um = w.mean_up_um - w.mean_down_um;
    w.mean_bidirectional_um = 0.5 * (w.mean_up_um + w.mean_down_um);
    w.repeatability_um = abs_scale * r.repeatability_um;
  }
}

void CheckApplicable(const CorrectionSettings& settings, const PositioningInputUncertainties& u) {
  const auto& names = PositioningInputNames();
  const double air[] = {u.air_temperature_c, u.air_pressure_pa, u.air_humidity_pct};
  for (std::size_t i = 0; i < 3 && !settings.air; ++i) {
    if (air[i] > 0.0) {
      throw InvalidInput("", 0, names[1 + i],
                         "applies to raw readings (air_compensated: no) only; the laser's own "
                         "air compensation belongs in u_laser_ppm");
    }
  }
  const double material[] = {u.material_temperature_c, u.expansion_ppm_per_k};
  for (std::size_t i = 0; i < 2 && !settings.material_temperature_c; ++i) {
    if (material[i] > 0.0) {
      throw InvalidInput("", 0, names[4 + i],
                         "needs material_temperature_c and expansion_ppm_per_k: without the "
                         "correction to 20 °C there is nothing to propagate it through");
    }
  }
}

// A figure the inputs do not move (R, B with the machine temperature alone: the scale of the
// readings is untouched) has draws that differ in their last bits only; u below 10⁻¹⁰ of the
// figure (at least of 1 µm) is that rounding, reported as 0, and its GUM check compares zeros.
void ZeroRounding(PositioningUncertainty& r) {
  constexpr double kRounding = 1e-10;
  for (std::size_t j = 0; j < r.mc.outputs.size(); ++j) {
    uncertainty::McOutput& o = r.mc.outputs[j];
    const double floor = kRounding * std::max(std::abs(o.mean), 1.0);
    if (o.u <= floor) o.u = o.U = 0.0;
    for (double& b : o.budget) b = b <= floor ? 0.0 : b;
    if (j >= r.gum.size()) continue;
    uncertainty::GumCheck& g = r.gum[j];
    if (g.u_gum <= floor) g.u_gum = 0.0;
    g.u_mc = o.u;
    const double d = std::abs(g.u_gum - g.u_mc);
    g.relative_difference = g.u_mc > 0.0 ? d / g.u_mc : (d > 0.0 ? HUGE_VAL : 0.0);
    g.differs = g.relative_difference > 0.05;
  }
}

}  // namespace

bool PositioningInputUncertainties::Any() const {
  return laser_ppm > 0.0 || air_temperature_c > 0.0 || air_pressure_pa > 0.0 ||
         air_humidity_pct > 0.0 || material_temperature_c > 0.0 || expansion_ppm_per_k > 0.0;
}

const std::vector<std::string>& PositioningInputNames() {
  static const std::vector<std::string> names = {
      "u_laser_ppm",        "u_air_temperature_c",      "u_air_pressure_pa",
      "u_air_humidity_pct", "u_material_temperature_c", "u_expansion_ppm_per_k"};
  return names;
}

const std::vector<std::string>& PositioningFigureKeys() {
  static const std::vector<std::string> keys = {"accuracy_um",
                                                "accuracy_up_um",
                                                "accuracy_down_um",
                                                "systematic_deviation_um",
                                                "systematic_deviation_up_um",
                                                "systematic_deviation_down_um",
                                                "mean_deviation_range_um",
                                                "reversal_value_um",
                                                "mean_reversal_value_um",
                                                "repeatability_um",
                                                "repeatability_up_um",
                                                "repeatability_down_um",
                                                "vdi3441.P_um",
                                                "vdi3441.Ps_um",
                                                "vdi3441.U_um",
                                                "vdi3441.Pa_um"};
  return keys;
}

std::vector<uncertainty::McInput> PositioningMcInputs(const CorrectionSettings& settings,
                                                      const PositioningInputUncertainties& u) {
  CheckApplicable(settings, u);
  const auto& names = PositioningInputNames();
  const AirConditions air = settings.air.value_or(AirConditions{});
  const double t = settings.material_temperature_c.value_or(20.0);
  using uncertainty::McInput;
  return {McInput::Normal(names[0], 0.0, u.laser_ppm * 1e-6),
          McInput::Normal(names[1], air.temperature_c, u.air_temperature_c),
          McInput::Normal(names[2], air.pressure_pa, u.air_pressure_pa),
          McInput::Normal(names[3], air.humidity_pct, u.air_humidity_pct),
          McInput::Normal(names[4], t, u.material_temperature_c),
          McInput::Normal(names[5], settings.expansion_ppm_per_k, u.expansion_ppm_per_k)};
}

uncertainty::VectorModel PositioningModel(const std::vector<TargetFigures>& raw,
                                          const CorrectionSettings& settings) {
  auto st = std::make_shared<DrawState>();
  st->raw = raw;
  st->work = raw;
  for (const auto& t : raw) st->distance_um.push_back((t.target_mm - settings.datum_mm) * 1000.0);
  st->air = settings.air;
  st->material = settings.material_temperature_c.has_value();
  return [st](std::span<const double> x, std::span<double> y) {
    double scale = 1.0 + x[0];
    if (st->air) scale /= RefractiveIndexOfAir(DrawnAir(*st->air, x[1], x[2], x[3]));
    // α (ppm/K) · (T − 20) K · d (µm) · 10⁻⁶.
    const double material_per_um = st->material ? x[5] * (x[4] - 20.0) * 1e-6 : 0.0;
    TransformTargets(*st, scale, material_per_um);
    const Iso230Figures a = AxisFigures(st->work);
    const Vdi3441Figures v = VdiFigures(st->work);
    const double out[] = {a.accuracy_um,
                          a.accuracy_up_um,
                          a.accuracy_down_um,
                          a.systematic_deviation_um,
                          a.systematic_deviation_up_um,
                          a.systematic_deviation_down_um,
                          a.mean_deviation_range_um,
                          a.reversal_value_um,
                          a.mean_reversal_value_um,
                          a.repeatability_um,
                          a.repeatability_up_um,
                          a.repeatability_down_um,
                          v.position_uncertainty_um,
                          v.position_scatter_um,
                          v.reversal_span_um,
                          v.position_deviation_um};
    std::copy(std::begin(out), std::end(out), y.begin());
  };
}

PositioningUncertainty PropagatePositioningUncertainty(const std::vector<TargetFigures>& raw,
                                                       const CorrectionSettings& settings,
                                                       const PositioningInputUncertainties& u,
                                                       const uncertainty::McOptions& options) {
  const auto inputs = PositioningMcInputs(settings, u);
  const auto model = PositioningModel(raw, settings);
  const auto& keys = PositioningFigureKeys();
  PositioningUncertainty out;
  out.mc = uncertainty::PropagateMonteCarlo(model, inputs, keys.size(), options);
  out.gum = uncertainty::CrossCheckGum(model, inputs, out.mc, keys);
  ZeroRounding(out);
  return out;
}

PositioningUncertainty PropagatePositioningUncertainty(const std::vector<TargetFigures>& raw,
                                                       const CorrectionSettings& settings,
                                                       const PositioningInputUncertainties& u) {
  uncertainty::McOptions o;
  o.draws = kPositioningDraws;
  o.budget_draws = kPositioningBudgetDraws;
  o.seed = kPositioningSeed;
  return PropagatePositioningUncertainty(raw, settings, u, o);
}

}  // namespace km::positioning
