// Compensation preview ([PM-600 report] eq. 4.5, table 4.5) for a machine calibrated with
// effects (effect_fit.h): per test, the trace predicted once the kinematic errors are calibrated
// out (the fit's residual plus every modelled effect), without and with the command corrected by
// the modelled gravity (and friction) deflection, and the circularity (eq. 4.8) of each and of
// the measured trace. The effects' change of each sample is taken to first order through the
// fit's sensitivities.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "analysis/dbb/dbb_types.h"
#include "analysis/hexapod/effect_fit.h"

namespace km::hexapod {

struct CompensatedTest {
  std::string test_id;
  dbb::Direction direction = dbb::Direction::kCcw;
  double circularity_measured_um = 0.0;
  double circularity_without_compensation_um = 0.0;
  double predicted_circularity_with_compensation_um = 0.0;
};

struct CompensationPreview {
  std::vector<std::string> compensated_effects;  // gravity_deflection and/or joint_friction
  std::vector<CompensatedTest> tests;  // a test with no circle (< 3 distinct samples) left out
};

// nullopt when the fit models neither gravity deflection nor joint friction.
std::optional<CompensationPreview> PreviewCompensation(const EffectFitData& d,
                                                       const EffectFitResult& fit);

}  // namespace km::hexapod
