// The figures a hexapod discovery report shows beside the engine's steps (docs/formats.md §3),
// computed from the fit data and the fit history, before any JSON: each test's gap before and
// after a step, the measured and modelled traces of the test with the largest gap, and the
// compensation preview of the final model ([PM-600 report] eq. 4.5). discovery_json.cpp maps
// them to JSON.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/dbb/dbb_types.h"
#include "analysis/discovery/engine.h"
#include "analysis/hexapod/compensation.h"
#include "analysis/hexapod/effect_fit.h"

namespace km::usecases {

// The rms of one test's rows of a residual (model − measured), before and (when given) after.
struct TestGap {
  std::string test_id;
  dbb::Direction direction = dbb::Direction::kCcw;
  std::optional<std::string> file;  // the uploaded file's name, when the study names it
  double gap_rms_before_um = 0.0;
  std::optional<double> gap_rms_after_um;
};

// One test's bar deviation (≤ 360 points) measured, and as the model before and after a step
// predicts it (measured + residual), each about the least-squares circle of the measured trace
// (its mean and first harmonic removed), so that form differences of a µm show beside a large
// centre offset.
struct TestTraces {
  std::string test_id;
  dbb::Direction direction = dbb::Direction::kCcw;
  std::vector<double> angle_deg, measured_um, model_before_um, model_after_um;
};

struct DiscoveryStepFigures {
  std::vector<TestGap> tests;
  TestTraces worst_test;  // the test with the largest gap before the step
};

struct HexapodDiscoveryFigures {
  std::vector<TestGap> base_tests;  // under the kinematic model alone
  std::vector<DiscoveryStepFigures> steps;
  std::vector<TestGap> final_tests;
  std::optional<hexapod::CompensationPreview> compensation;  // with gravity or friction modelled
};

// `history` holds the fit before the first step and after each step (r.steps.size() + 1).
HexapodDiscoveryFigures ComputeHexapodDiscoveryFigures(
    const hexapod::EffectFitData& data, const std::vector<hexapod::EffectFitResult>& history,
    const discovery::EngineResult& r, const std::vector<std::string>& names);

// Each test's gap under `before` and, when given, `after`.
std::vector<TestGap> TestGaps(const hexapod::EffectFitData& d, const Eigen::VectorXd& before,
                              const Eigen::VectorXd* after, const std::vector<std::string>& names);

// The traces of the test with the largest gap under `before`.
TestTraces WorstTestTraces(const hexapod::EffectFitData& d, const Eigen::VectorXd& before,
                           const Eigen::VectorXd& after);

}  // namespace km::usecases
