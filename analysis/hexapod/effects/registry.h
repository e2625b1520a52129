// Registry of the hexapod effects of effect_list.h, and the evaluation of a set of active
// effects on a test (the sum of their strut-length and tool-length changes).
#pragma once

#include <string>
#include <vector>

#include "analysis/hexapod/effects/effect.h"

namespace km::hexapod {

const std::vector<const HexapodEffect*>& HexapodEffects();
// nullptr when the name is not a hexapod effect.
const HexapodEffect* FindHexapodEffect(const std::string& name);
// Comma-separated names of every effect (for messages).
std::string HexapodEffectNames();

// An effect of a model with its parameter values (same order as Parameters()).
struct ActiveEffect {
  const HexapodEffect* effect = nullptr;
  std::vector<EffectParameter> params;
};

// The compliance term K_stiff2 of a model: gravity_deflection's when active, else the machine's.
ModelTerms TermsOf(const std::vector<ActiveEffect>& model, const MachinePhysics* physics);

// Sum of the effects' perturbations on one test.
void ApplyEffects(const std::vector<ActiveEffect>& model, const TestPath& path,
                  const EffectSetup& setup, Perturbation& out);

}  // namespace km::hexapod
