#include "analysis/hexapod/effects/registry.h"

#include "analysis/hexapod/effects/effect_list.h"

namespace km::hexapod {

const std::vector<const HexapodEffect*>& HexapodEffects() {
  static const std::vector<const HexapodEffect*> list = {
#define KM_HEXAPOD_EFFECT_PTR(id) &id##Effect(),
      KM_HEXAPOD_EFFECT_LIST(KM_HEXAPOD_EFFECT_PTR)
#undef KM_HEXAPOD_EFFECT_PTR
  };
  return list;
}

const HexapodEffect* FindHexapodEffect(const std::string& name) {
  for (const auto* e : HexapodEffects())
    if (name == e->Name()) return e;
  return nullptr;
}

std::string HexapodEffectNames() {
  std::string s;
  for (const auto* e : HexapodEffects()) s += (s.empty() ? "" : ", ") + std::string(e->Name());
  return s;
}

ModelTerms TermsOf(const std::vector<ActiveEffect>& model, const MachinePhysics* physics) {
  ModelTerms t;
  t.physics = physics;
  if (physics) t.k_stiff2_mm_per_N = physics->compliance_other_mm_per_N;
  for (const auto& a : model)
    if (a.effect == &GravityDeflectionEffect() && physics) {
      std::vector<double> v;
      for (const auto& p : a.params) v.push_back(p.value);
      t.k_stiff2_mm_per_N = v[0];
      PlatformTerms(*physics, v.data(), t);
    }
  return t;
}

void ApplyEffects(const std::vector<ActiveEffect>& model, const TestPath& path,
                  const EffectSetup& setup, Perturbation& out) {
  out.Reset(path.pose.size());
  const ModelTerms terms = TermsOf(model, setup.physics);
  std::vector<double> values;
  for (const auto& a : model) {
    values.clear();
    for (const auto& p : a.params) values.push_back(p.value);
    a.effect->Apply(path, values.data(), terms, setup, out);
  }
}

}  // namespace km::hexapod
