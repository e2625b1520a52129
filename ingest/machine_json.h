// Machine definition files, `"format": "kinemetric-machine/1"` (docs/formats.md §2), for hexapods:
// base_joints_mm (6×3, machine frame), platform_joints_mm (6×3, platform frame), strut_offset_mm
// (6; convention of analysis/hexapod/kinematics.h). Every error is a km::InvalidInput naming
// the file and the field (e.g. "base_joints_mm[2][1]"). Writing keeps every other key of the
// original document (gravity, friction, description, extra keys) unchanged.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/hexapod/kinematics.h"
#include "ingest/machine_physics.h"

namespace km::ingest {

inline constexpr const char* kMachineFormat = "kinemetric-machine/1";

struct MachineDefinition {
  std::string machine_id;
  std::string kind;                   // "hexapod" or "serial"
  hexapod::HexapodGeometry geometry;  // filled for kind == "hexapod"
  // Hexapods: the gravity / friction blocks (docs/hexapod-effects.md) and the effects of the
  // machine's model with their fitted parameters (the "effects" block).
  std::optional<hexapod::MachinePhysics> physics;
  std::vector<MachineEffect> effects;
  std::string source_json;  // the original document (kept for write-back)
};

// Parses and validates. Throws km::InvalidInput (file, field).
MachineDefinition ParseMachineJson(std::string_view bytes, const std::string& file);

// Same as ParseMachineJson and additionally requires kind == "hexapod".
MachineDefinition ParseHexapodMachineJson(std::string_view bytes, const std::string& file);

// The document with base_joints_mm, platform_joints_mm and strut_offset_mm replaced by
// `machine.geometry` (and machine_id), other keys kept; pretty-printed (indent 2), numbers
// with full double precision.
std::string WriteMachineJson(const MachineDefinition& machine);

}  // namespace km::ingest
