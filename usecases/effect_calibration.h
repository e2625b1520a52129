// Hexapod calibration with effects ([PM-600 report] ch. 5 eq. 5.3, [Joint patent] formulas
// 15–20): the 24 kinematic parameters and the free parameters of the named effects fitted
// together (analysis/hexapod/effect_fit.h), reported with the keys of `kinemetric hexapod
// calibrate` plus `effects[]`. Used by RunCalibrationStudy when effects are asked for.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "analysis/core/progress.h"
#include "analysis/dbb/dbb_types.h"
#include "analysis/hexapod/effect_fit.h"
#include "analysis/hexapod/effects/registry.h"
#include "usecases/calibration_types.h"

namespace km::usecases {

// Start time of every test (Unix seconds) from its timestamp; nullopt for a test without one.
// Throws km::InvalidInput naming the file when a timestamp is not ISO 8601.
std::vector<std::optional<double>> TestStartTimes(const std::vector<dbb::DbbTest>& tests,
                                                  const std::vector<std::string>& names);

// The effect-fit problem of these tests on the machine (PrepareEffectFit); a test the effects
// cannot read (e.g. a commanded motion that turns back) is refused naming its file.
hexapod::EffectFitData PrepareNamedEffectFit(const ingest::MachineDefinition& machine,
                                             const std::vector<dbb::DbbTest>& tests,
                                             const std::vector<std::string>& names,
                                             hexapod::CalibrationMethod method,
                                             int max_samples_per_test);

// The effects named (comma-separated list or vector), with their defaults for these tests and
// the machine's stored values where its model has them. Throws km::InvalidInput (field
// `field`) for an unknown name or an effect the data cannot support.
std::vector<hexapod::ActiveEffect> ResolveEffects(const std::vector<std::string>& names,
                                                  const ingest::MachineDefinition& machine,
                                                  const hexapod::EffectSetup& setup,
                                                  const std::string& field);

// The machine's stored effects (its "effects" block) that are not named take part with their
// stored values held fixed.
CalibrationOutcome RunEffectCalibration(const CalibrationStudy& study, const ProgressFn& progress);

}  // namespace km::usecases
