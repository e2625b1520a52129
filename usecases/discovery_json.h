// JSON of `kinemetric discover` (docs/formats.md §3) for the hexapod family (the serial
// family's is in discovery_report.cpp): a mapping of the engine's result and of the figures
// computed beside it (hexapod_discovery_figures.h), nothing computed here. Used by
// usecases/discovery_report.cpp.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/discovery/engine.h"
#include "analysis/hexapod/effect_fit.h"
#include "ingest/machine_json.h"
#include "usecases/hexapod_discovery_figures.h"

namespace km::usecases {

nlohmann::json HexapodDiscoveryJson(const ingest::MachineDefinition& machine,
                                    const hexapod::EffectFitData& data,
                                    const std::vector<hexapod::EffectFitResult>& history,
                                    const discovery::EngineResult& r,
                                    const HexapodDiscoveryFigures& figures);

// {"strut_offset_um": [6], "base_joint_offset_um": [6][3]} of a kinematic parameter vector.
nlohmann::json KinematicJson(const hexapod::ParameterVector& k);

// One fitted effect: {effect, parameters {name: value}, uncertainty {name: σ}, value, sigma,
// unit (of the first parameter), fixed_parameters}.
nlohmann::json EffectModelJson(const hexapod::ActiveEffect& a, const std::vector<double>& sigma,
                               const std::vector<bool>& at_bound = {});

// One candidate of a discovery step: effect, variant, the fit with it, the held-out prediction,
// its p-value and whether it qualified (or why not).
nlohmann::json CandidateJson(const discovery::CandidateScore& c);

}  // namespace km::usecases
