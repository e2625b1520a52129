// The missing-effect workflow of an R-test (docs/methods.md §17.6), with the mechanics of the
// hexapod's discovery (docs/hexapod-effects.md): start from the eight location errors; each step
// fit every candidate not yet named (rotary_effects.h) jointly with the location errors and the
// effects already named, and name the one that removes most of the gap when it passes both
//   – the nested-model F-test: P(F_{q, 3N − rank} > F) < false_alarm, q the rank it adds;
//   – a practical size: the RSS drop exceeds practical_factor × q × s² (s from the larger
//     model), i.e. many times what q parameters fitted to noise alone would remove (q s²).
// Stop when no candidate passes. The verdict is "complete" when the rest is within
// misfit_factor × the noise (u_reading_um, else s cannot be judged: "no noise level"), else
// "model misfit" with the rest described in words.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "analysis/rotary/rotary_effects.h"

namespace km::rotary {

struct DiscoverOptions {
  double false_alarm = 1e-3;
  double practical_factor = 10.0;
  double misfit_factor = 1.3;
  void Check() const;
};

struct CandidateTrial {
  RotaryEffect effect = RotaryEffect::kCAngular;
  std::size_t added_rank = 0;
  double rms_after_um = 0.0;
  double f = 0.0;
  double p_value = 1.0;
  bool significant = false;
  bool practical = false;
};

struct DiscoverStep {
  std::optional<RotaryEffect> named;  // none: the first step (location errors only)
  double rms_before_um = 0.0;         // the gap before the step
  double rms_after_um = 0.0;          // and after it
  double s_um = 0.0;
  std::vector<CandidateTrial> candidates;  // every candidate tried at this step
};

struct RotaryDiscovery {
  Kinematics kinematics = Kinematics::kAcTrunnion;
  std::vector<DiscoverStep> steps;  // steps[0]: location errors from the readings
  std::vector<RotaryEffect> named;  // in the order named
  EffectFit final_fit;              // location errors and every named effect
  std::optional<double> noise_um;   // u_reading_um
  std::string verdict;              // "complete", "model misfit", "no noise level"
  std::string misfit;               // the rest described in words; empty unless a misfit
  bool has_time = false;
};

// time_s may be empty (the drift candidate is then not tried).
RotaryDiscovery DiscoverRotaryEffects(const RotaryTest& test, const std::vector<double>& time_s,
                                      std::optional<double> noise_um,
                                      const DiscoverOptions& options = {});

}  // namespace km::rotary
