// servo_lag for hexapods: each strut follows its command through a position loop with velocity
// feed-forward; on a smooth path the realised length differs by Δs_j = (c/2)·s̈_j with
// c = (1 − K_f²)/K_pp² — the strut-space form of [Fujita thesis] eq. 2.1 (on a circle the tool
// radius shrinks by c·V²/(2R)). s̈_j: second time derivative of the commanded strut length
// along the path at the test's feed (central differences over the sample times).
#include <algorithm>

#include "analysis/hexapod/effects/effect_list.h"

namespace km::hexapod {
namespace {

class ServoLag final : public HexapodEffect {
 public:
  const char* Name() const override { return "servo_lag"; }
  std::vector<EffectParameter> Parameters(const EffectSetup&) const override {
    return {{"lag_coefficient_ms2", "ms2", 0.0, 0.0, 1e4, true, 10.0}};
  }
  void Apply(const TestPath& path, const double* p, const ModelTerms&, const EffectSetup&,
             Perturbation& out) const override {
    const std::size_t n = path.pose.size();
    if (n < 3 || !(path.feed_mm_min > 0.0)) return;
    const double c_s2 = 1e-6 * p[0];
    for (std::size_t i = 0; i < n; ++i) {
      // Neighbours inside the test (one-sided at the ends).
      const std::size_t m = std::clamp<std::size_t>(i, 1, n - 2);
      const double h1 = path.time_s[m] - path.time_s[m - 1];
      const double h2 = path.time_s[m + 1] - path.time_s[m];
      if (!(h1 > 0.0) || !(h2 > 0.0)) continue;
      const Vector6d acc = 2.0 *
                           ((path.strut_mm[m + 1] - path.strut_mm[m]) / h2 -
                            (path.strut_mm[m] - path.strut_mm[m - 1]) / h1) /
                           (h1 + h2);
      out.ds_mm[i] += 0.5 * c_s2 * acc;
    }
  }
  const char* Signature() const override {
    return "a radius change that scales with feed squared over radius, alike in CW and CCW";
  }
};

}  // namespace

const HexapodEffect& ServoLagEffect() {
  static const ServoLag e;
  return e;
}

}  // namespace km::hexapod
