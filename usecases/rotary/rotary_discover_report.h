// The missing-effect workflow of an R-test file (docs/formats.md §3.18, docs/methods.md §17.6),
// shared by the CLI (`kinemetric rotary discover`) and any other caller: the discovery of
// analysis/rotary/rotary_discover.h on the parsed file and its JSON object.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "analysis/rotary/rotary_discover.h"
#include "ingest/rotary/rotary_parser.h"

namespace km::usecases {

inline constexpr const char* kRotaryDiscoveryVersion = "rotary-discover/1";

struct RotaryDiscoveryReport {
  ingest::RotaryFile file;
  rotary::RotaryDiscovery result;
};

RotaryDiscoveryReport DiscoverRotary(ingest::RotaryFile file);

// One sentence per step: "step 1: angular positioning error of C named (F = …, p = …): gap
// 3.10 → 0.71 µm".
std::vector<std::string> RotaryDiscoverySteps(const RotaryDiscoveryReport& r);

nlohmann::json RotaryDiscoveryToJson(const RotaryDiscoveryReport& r);

}  // namespace km::usecases
