// The machine a hexapod calibration or discovery leaves behind: the nominal geometry moved by
// the fitted kinematic parameters, and the fitted effects as the machine's "effects" block
// (docs/formats.md §2). A caller stores it as the machine model's next version.
#pragma once

#include "analysis/hexapod/effect_fit.h"
#include "ingest/machine_json.h"

namespace km::usecases {

ingest::MachineDefinition UpdatedMachine(const ingest::MachineDefinition& machine,
                                         const hexapod::EffectFitResult& fit);

}  // namespace km::usecases
