// gravity_deflection ([PM-600 report] eqs. 3.4–3.8, 4.1–4.4): the struts stretch under the
// platform's and their own weight, Δs_j = K_j F_j with K_j = K_stiff1 (L_j − l2)/l3 + K_stiff2;
// K_stiff1 fixed at the machine's value (only the sum is observable), K_stiff2 free. The
// platform's mass and centre of gravity (eqs. 3.6–3.7) are the machine file's unless a variant
// fits them: a platform heavier than its file, or with its centre off axis, loads the struts
// differently at every tilt, and that belongs to this effect, not to any other.
#include <algorithm>

#include "analysis/hexapod/effects/effect_list.h"

namespace km::hexapod {
namespace {

enum : int { kK2 = 0, kMass, kCogX, kCogY, kCogZ };

class GravityDeflection final : public HexapodEffect {
 public:
  const char* Name() const override { return "gravity_deflection"; }
  std::vector<EffectParameter> Parameters(const EffectSetup& s) const override {
    if (!s.physics || !s.physics->has_gravity) return {};
    const double k2 = s.physics->compliance_other_mm_per_N;
    const double m = s.physics->platform_mass_kg;
    const auto& c = s.physics->platform_cog_mm;
    return {{"K_stiff2_mm_per_N", "mm/N", k2 > 0.0 ? k2 : 1e-5, 0.0, 1e-3, true, 1e-5},
            {"platform_mass_kg", "kg", m, 0.0, 1e5, false, std::max(1.0, 0.1 * m)},
            {"platform_cog_mm[0]", "mm", c.x(), -1e4, 1e4, false, 20.0},
            {"platform_cog_mm[1]", "mm", c.y(), -1e4, 1e4, false, 20.0},
            {"platform_cog_mm[2]", "mm", c.z(), -1e4, 1e4, false, 20.0}};
  }
  std::vector<Variant> Variants(const EffectSetup& s) const override {
    auto plain = Parameters(s);
    if (plain.empty()) return {};
    // The centre across the spindle axis moves the platform's moment at every tilt; along the
    // axis it acts only through the tilt, like the tool length, and is left to the file.
    auto mass = plain;
    mass[kMass].free = true;
    auto centre = plain;
    centre[kCogX].free = centre[kCogY].free = true;
    auto both = centre;
    both[kMass].free = true;
    return {{"", plain, {}},
            {"platform mass fitted", mass, {}},
            {"platform centre fitted", centre, {}},
            {"platform mass and centre fitted", both, {}}};
  }
  void Apply(const TestPath& path, const double* p, const ModelTerms& terms, const EffectSetup& s,
             Perturbation& out) const override {
    if (path.gravity_N.empty()) return;
    ModelTerms own = terms;
    PlatformTerms(*s.physics, p, own);
    for (std::size_t i = 0; i < path.pose.size(); ++i) {
      const Vector6d k = StrutCompliance(*s.physics, path.frame[i], p[kK2]);
      out.ds_mm[i] += k.cwiseProduct(own.GravityAt(path, i));
    }
  }
  const char* Signature() const override {
    return "the same in CW and CCW (even), growing with the spindle tilt and the platform "
           "position, because the struts stretch under the platform's weight";
  }
};

}  // namespace

void PlatformTerms(const MachinePhysics& m, const double* p, ModelTerms& terms) {
  terms.platform_mass_change_kg = p[kMass] - m.platform_mass_kg;
  terms.platform_moment_change_kg_mm =
      p[kMass] * (Eigen::Vector3d(p[kCogX], p[kCogY], p[kCogZ]) - m.platform_cog_mm);
}

const HexapodEffect& GravityDeflectionEffect() {
  static const GravityDeflection e;
  return e;
}

}  // namespace km::hexapod
