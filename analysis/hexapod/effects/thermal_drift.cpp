// thermal_drift: the struts grow with time, or with the temperature of the test when every test
// carries one. Two forms, and the data choose between them in a discovery:
//   uniform                       Δs_j = rate·(t − t_ref)                 (µm/h; µm/K)
//   proportional to strut length  Δs_j = ε̇·L_j·(t − t_ref)              (ppm/h; ppm/K = α)
// the second being a uniform expansion of the strut material, α·L_j·ΔT. The time of each
// sample is the test's timestamp plus the path travelled at the test feed
// (docs/hexapod-effects.md).
#include "analysis/hexapod/effects/effect_list.h"

namespace km::hexapod {
namespace {

class ThermalDrift final : public HexapodEffect {
 public:
  const char* Name() const override { return "thermal_drift"; }
  std::vector<EffectParameter> Parameters(const EffectSetup& s) const override {
    if (s.all_temperatures) {
      return {{"um_per_K", "um/K", 0.0, -1000.0, 1000.0, true, 1.0},
              {"ppm_per_K", "ppm/K", 0.0, -1000.0, 1000.0, false, 1.0}};
    }
    if (!s.all_timed) return {};
    return {{"rate_um_per_h", "um/h", 0.0, -1000.0, 1000.0, true, 1.0},
            {"strain_ppm_per_h", "ppm/h", 0.0, -1000.0, 1000.0, false, 1.0}};
  }
  std::vector<Variant> Variants(const EffectSetup& s) const override {
    auto uniform = Parameters(s);
    if (uniform.empty()) return {};
    auto length = uniform;
    length[0].free = false;
    length[1].free = true;
    return {{"", uniform, {}}, {"proportional to strut length", length, {}}};
  }
  void Apply(const TestPath& path, const double* p, const ModelTerms&, const EffectSetup& s,
             Perturbation& out) const override {
    for (std::size_t i = 0; i < out.ds_mm.size(); ++i) {
      // Elapsed hours, or kelvin above the reference temperature.
      const double x = s.all_temperatures ? path.temperature_c.value_or(s.reference_temperature_c) -
                                                s.reference_temperature_c
                                          : path.time_s[i] / 3600.0;
      out.ds_mm[i].array() += 1e-3 * p[0] * x;
      if (p[1] == 0.0) continue;
      for (int j = 0; j < 6; ++j) out.ds_mm[i][j] += 1e-6 * p[1] * path.frame[i].length_mm[j] * x;
    }
  }
  const char* Signature() const override {
    return "a change that grows with the time (or temperature) of the test across the set, "
           "alike in CW and CCW";
  }
};

}  // namespace

const HexapodEffect& ThermalDriftEffect() {
  static const ThermalDrift e;
  return e;
}

}  // namespace km::hexapod
