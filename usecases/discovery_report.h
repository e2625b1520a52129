// Model-gap discovery study ([PM-600 report] ch. 4–5, [Joint patent]): from a set of DBB tests
// of one machine, name the physical effects the machine's model misses, fit them, and show the
// gap shrinking step by step (analysis/discovery/engine.h). Serial machines (no machine file, or
// kind "serial") use the serial effect family; hexapods the hexapod family, whose base model is
// the 24-parameter kinematic calibration. Maps the result to the JSON of `kinemetric discover`
// (docs/formats.md §3). Shared by the CLI and the server's background jobs.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/core/progress.h"
#include "analysis/dbb/dbb_types.h"
#include "ingest/machine_json.h"

namespace km::usecases {

struct DiscoveryStudy {
  std::optional<ingest::MachineDefinition> machine;  // none or serial: serial family
  std::vector<dbb::DbbTest> tests;
  std::vector<std::string> names;  // file names or "measurement N", for messages and output
  int max_samples_per_test = 0;    // 0: all samples
};

struct DiscoveryOutcome {
  nlohmann::json report;  // `kinemetric discover` keys
  // Hexapods: the machine with the calibrated geometry and the discovered effects (the
  // "effects" block of the machine file), ready to be stored as a new version of its model.
  std::optional<ingest::MachineDefinition> updated_machine;
};

// Throws km::InvalidInput naming the test (file) and field when the tests cannot be used.
DiscoveryOutcome RunDiscoveryStudy(const DiscoveryStudy& study, const ProgressFn& progress = {});

}  // namespace km::usecases
