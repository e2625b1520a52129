#include "usecases/updated_machine.h"

#include <utility>

#include "analysis/hexapod/calibration.h"

namespace km::usecases {

ingest::MachineDefinition UpdatedMachine(const ingest::MachineDefinition& machine,
                                         const hexapod::EffectFitResult& fit) {
  ingest::MachineDefinition m = machine;
  m.geometry = hexapod::ApplyParameters(machine.geometry, fit.k_um);
  m.effects.clear();
  for (const auto& a : fit.effects) {
    ingest::MachineEffect me;
    me.effect = a.effect->Name();
    for (const auto& p : a.params) me.parameters.emplace_back(p.name, p.value);
    m.effects.push_back(std::move(me));
  }
  return m;
}

}  // namespace km::usecases
