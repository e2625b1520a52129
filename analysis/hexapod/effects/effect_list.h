// THE list of hexapod error effects (docs/hexapod-effects.md). One line per effect; each is
// defined in its own file of this folder as `const HexapodEffect& <Id>Effect()`. The order is
// the priority when two effects cannot be told apart from the data (the earlier is kept).
#pragma once

#include "analysis/hexapod/effects/effect.h"

#define KM_HEXAPOD_EFFECT_LIST(X) \
  X(GravityDeflection)            \
  X(JointFriction)                \
  X(ToolLengthError)              \
  X(ThermalDrift)                 \
  X(ServoLag)

namespace km::hexapod {
#define KM_DECLARE_HEXAPOD_EFFECT(id) const HexapodEffect& id##Effect();
KM_HEXAPOD_EFFECT_LIST(KM_DECLARE_HEXAPOD_EFFECT)
#undef KM_DECLARE_HEXAPOD_EFFECT
// The platform mass and centre of gravity_deflection's parameters `p` as changes from the
// machine file (ModelTerms::GravityAt).
void PlatformTerms(const MachinePhysics& m, const double* p, ModelTerms& terms);
}  // namespace km::hexapod
