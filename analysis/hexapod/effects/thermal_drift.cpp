// thermal_drift: every strut grows with time, rate·(t − t_ref) (µm/h), or with the temperature
// of the test when every test carries one, k·(T − T_ref) (µm/K). The time of each sample is the
// test's timestamp plus the path travelled at the test feed (docs/hexapod-effects.md).
#include "analysis/hexapod/effects/effect_list.h"

namespace km::hexapod {
namespace {

class ThermalDrift final : public HexapodEffect {
 public:
  const char* Name() const override { return "thermal_drift"; }
  std::vector<EffectParameter> Parameters(const EffectSetup& s) const override {
    if (s.all_temperatures) return {{"um_per_K", "um/K", 0.0, -1000.0, 1000.0, true, 1.0}};
    if (!s.all_timed) return {};
    return {{"rate_um_per_h", "um/h", 0.0, -1000.0, 1000.0, true, 1.0}};
  }
  void Apply(const TestPath& path, const double* p, const ModelTerms&, const EffectSetup& s,
             Perturbation& out) const override {
    if (s.all_temperatures) {
      const double d =
          1e-3 * p[0] *
          (path.temperature_c.value_or(s.reference_temperature_c) - s.reference_temperature_c);
      for (auto& ds : out.ds_mm) ds.array() += d;
      return;
    }
    for (std::size_t i = 0; i < out.ds_mm.size(); ++i)
      out.ds_mm[i].array() += 1e-3 * p[0] * path.time_s[i] / 3600.0;
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
