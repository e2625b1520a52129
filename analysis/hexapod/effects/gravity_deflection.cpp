// gravity_deflection ([PM-600 report] eqs. 3.4–3.8, 4.1–4.4): the struts stretch under the
// platform's and their own weight, Δs_j = K_j F_j with K_j = K_stiff1 (L_j − l2)/l3 + K_stiff2;
// K_stiff1 fixed at the machine's value (only the sum is observable), K_stiff2 free.
#include "analysis/hexapod/effects/effect_list.h"

namespace km::hexapod {
namespace {

class GravityDeflection final : public HexapodEffect {
 public:
  const char* Name() const override { return "gravity_deflection"; }
  std::vector<EffectParameter> Parameters(const EffectSetup& s) const override {
    if (!s.physics || !s.physics->has_gravity) return {};
    const double k2 = s.physics->compliance_other_mm_per_N;
    return {{"K_stiff2_mm_per_N", "mm/N", k2 > 0.0 ? k2 : 1e-5, 0.0, 1e-3, true, 1e-5}};
  }
  void Apply(const TestPath& path, const double* p, const ModelTerms& terms, const EffectSetup& s,
             Perturbation& out) const override {
    if (path.gravity_N.empty()) return;
    for (std::size_t i = 0; i < path.pose.size(); ++i) {
      const Vector6d k = StrutCompliance(*s.physics, path.frame[i], p[0]);
      out.ds_mm[i] += k.cwiseProduct(path.gravity_N[i]);
    }
    (void)terms;
  }
  const char* Signature() const override {
    return "the same in CW and CCW (even), growing with the spindle tilt and the platform "
           "position, because the struts stretch under the platform's weight";
  }
};

}  // namespace

const HexapodEffect& GravityDeflectionEffect() {
  static const GravityDeflection e;
  return e;
}

}  // namespace km::hexapod
