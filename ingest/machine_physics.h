// The `gravity`, `friction` and `effects` blocks of a hexapod machine file (docs/formats.md §2,
// docs/hexapod-effects.md). Errors name the file and the field.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/hexapod/statics.h"

namespace km::ingest {

// An effect of the machine's model with its fitted parameter values.
struct MachineEffect {
  std::string effect;
  std::vector<std::pair<std::string, double>> parameters;
};

// nullopt when the file has neither a gravity nor a friction block.
std::optional<hexapod::MachinePhysics> ParseMachinePhysics(const nlohmann::json& doc,
                                                           const std::string& file);
std::vector<MachineEffect> ParseMachineEffects(const nlohmann::json& doc, const std::string& file);
nlohmann::json MachineEffectsJson(const std::vector<MachineEffect>& effects);

}  // namespace km::ingest
