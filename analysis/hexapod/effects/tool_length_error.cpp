// tool_length_error ([PM-600 report] table 4.4 note: 104.255 mm programmed, 104.193 mm real):
// the real tool differs in length from the one the controller uses. One value per tool length
// of the test set, since one tool can be wrong and another right.
#include <cmath>
#include <cstdio>

#include "analysis/hexapod/effects/effect_list.h"

namespace km::hexapod {
namespace {

std::string ToolName(double l) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "error_um[%g]", l);
  return buf;
}

class ToolLengthError final : public HexapodEffect {
 public:
  const char* Name() const override { return "tool_length_error"; }
  std::vector<EffectParameter> Parameters(const EffectSetup& s) const override {
    std::vector<EffectParameter> p;
    for (double l : s.tool_lengths_mm)
      p.push_back({ToolName(l), "um", 0.0, -5000.0, 5000.0, true, 10.0});
    return p;
  }
  void Apply(const TestPath& path, const double* p, const ModelTerms&, const EffectSetup& s,
             Perturbation& out) const override {
    for (std::size_t t = 0; t < s.tool_lengths_mm.size(); ++t) {
      if (std::abs(s.tool_lengths_mm[t] - path.tool_length_mm) > 1e-9) continue;
      for (double& dl : out.dl_mm) dl += 1e-3 * p[t];
    }
  }
  const char* Signature() const override {
    return "a shift of the tool tip along the spindle axis that depends on which tool was used "
           "and shows in tilted and cone tests";
  }
};

}  // namespace

const HexapodEffect& ToolLengthErrorEffect() {
  static const ToolLengthError e;
  return e;
}

}  // namespace km::hexapod
