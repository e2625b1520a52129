#include "usecases/effect_calibration.h"

#include <algorithm>

#include "analysis/core/errors.h"
#include "analysis/hexapod/effect_fit.h"
#include "ingest/iso8601.h"
#include "usecases/discovery_json.h"
#include "usecases/updated_machine.h"

namespace km::usecases {

std::vector<std::optional<double>> TestStartTimes(const std::vector<dbb::DbbTest>& tests,
                                                  const std::vector<std::string>& names) {
  std::vector<std::optional<double>> out;
  for (std::size_t k = 0; k < tests.size(); ++k) {
    if (!tests[k].timestamp) {
      out.emplace_back();
      continue;
    }
    const auto s = ingest::Iso8601EpochSeconds(*tests[k].timestamp);
    if (!s) {
      throw InvalidInput(k < names.size() ? names[k] : tests[k].test_id, 0, "timestamp",
                         "not an ISO 8601 time: '" + *tests[k].timestamp + "'");
    }
    out.push_back(*s);
  }
  return out;
}

hexapod::EffectFitData PrepareNamedEffectFit(const ingest::MachineDefinition& machine,
                                             const std::vector<dbb::DbbTest>& tests,
                                             const std::vector<std::string>& names,
                                             hexapod::CalibrationMethod method,
                                             int max_samples_per_test) {
  const hexapod::MachinePhysics* physics = machine.physics ? &*machine.physics : nullptr;
  try {
    return hexapod::PrepareEffectFit(machine.geometry, physics, tests, TestStartTimes(tests, names),
                                     method, max_samples_per_test);
  } catch (const InvalidInput& e) {
    // Name the file rather than the test id.
    for (std::size_t k = 0; k < tests.size() && k < names.size(); ++k)
      if (tests[k].test_id == e.file())
        throw InvalidInput(names[k], e.line(), e.field(), e.reason());
    throw;
  }
}

std::vector<hexapod::ActiveEffect> ResolveEffects(const std::vector<std::string>& names,
                                                  const ingest::MachineDefinition& machine,
                                                  const hexapod::EffectSetup& setup,
                                                  const std::string& field) {
  std::vector<hexapod::ActiveEffect> out;
  for (const auto& name : names) {
    const auto* e = hexapod::FindHexapodEffect(name);
    if (!e) {
      throw InvalidInput(
          "", 0, field,
          "'" + name + "' is not a hexapod effect (" + hexapod::HexapodEffectNames() + ")");
    }
    if (std::any_of(out.begin(), out.end(), [&](const auto& a) { return a.effect == e; }))
      throw InvalidInput("", 0, field, name + " is listed twice");
    hexapod::ActiveEffect a{e, e->Parameters(setup)};
    if (a.params.empty()) {
      throw InvalidInput("", 0, field,
                         name +
                             " cannot be modelled for these tests (the machine file lacks its "
                             "gravity block, or the tests lack timestamps)");
    }
    for (const auto& me : machine.effects) {
      if (me.effect != name) continue;
      for (const auto& [pn, v] : me.parameters)
        for (auto& p : a.params)
          if (p.name == pn) p.value = std::clamp(v, p.lower, p.upper);
    }
    out.push_back(std::move(a));
  }
  return out;
}

CalibrationOutcome RunEffectCalibration(const CalibrationStudy& study, const ProgressFn& progress) {
  auto report = [&](double f, const std::string& stage) {
    if (progress) progress(f, stage);
  };
  bool all_have_ball = true;
  for (const auto& t : study.tests) all_have_ball = all_have_ball && t.fixed_ball_mm.has_value();
  const auto method =
      study.method.value_or(all_have_ball ? hexapod::CalibrationMethod::kAbsolute
                                          : hexapod::CalibrationMethod::kCentreCorrected);
  const auto& machine = study.machine;
  report(0.05, "preparing the tests");
  const auto data =
      PrepareNamedEffectFit(machine, study.tests, study.names, method, study.max_samples_per_test);
  auto start = hexapod::StartingPoint(data, {});
  start.effects = ResolveEffects(study.effects, machine, data.prepared.setup, "--effects");
  // The machine model's own effects that were not named: known, kept at their stored values
  // ([PM-600 report] eq. 5.3: the modelled gravity is taken out before the kinematics are fitted).
  for (const auto& me : machine.effects) {
    if (std::find(study.effects.begin(), study.effects.end(), me.effect) != study.effects.end())
      continue;
    auto known = ResolveEffects({me.effect}, machine, data.prepared.setup, "effects");
    for (auto& p : known.front().params) p.free = false;
    start.effects.push_back(std::move(known.front()));
  }
  report(0.1, "calibrating kinematics and effects");
  const auto fit = hexapod::FitWithEffects(data, start);
  report(0.8, "predicting the traces after calibration");
  const auto calibrated = hexapod::ApplyParameters(machine.geometry, fit.k_um);
  const auto pred = hexapod::PredictAfterCalibration(machine.geometry, calibrated, study.tests,
                                                     fit.fixed_balls_mm);
  nlohmann::json j;
  j["method"] = hexapod::ToString(method);
  j["parameters"] = KinematicJson(fit.k_um);
  j["parameter_uncertainty_um"] = KinematicJson(fit.k_sigma_um);
  j["fixed_parameters"] = nlohmann::json::array();
  for (int i = 0; i < hexapod::kNumKinematicParameters; ++i)
    if (data.problem.fixed[static_cast<std::size_t>(i)])
      j["fixed_parameters"].push_back(hexapod::ParameterName(i));
  j["tests"] = nlohmann::json::array();
  for (std::size_t i = 0; i < pred.size(); ++i) {
    nlohmann::json t = {{"test_id", pred[i].test_id},
                        {"direction", dbb::ToString(pred[i].direction)},
                        {"circularity_before_um", pred[i].circularity_before_um},
                        {"predicted_circularity_after_um", pred[i].predicted_circularity_after_um}};
    if (i < study.names.size()) t["file"] = study.names[i];
    j["tests"].push_back(t);
  }
  j["effects"] = nlohmann::json::array();
  for (std::size_t e = 0; e < fit.effects.size(); ++e)
    j["effects"].push_back(EffectModelJson(
        fit.effects[e], fit.effect_sigma[e],
        e < fit.effect_at_bound.size() ? fit.effect_at_bound[e] : std::vector<bool>{}));
  j["residual_rms_um"] = fit.residual_rms_um;
  j["condition_number"] = fit.condition_number;
  j["iterations"] = fit.iterations;
  j["converged"] = fit.converged;
  j["stop_reason"] = fit.stop_reason;
  CalibrationOutcome out;
  out.report = j;
  out.calibrated = UpdatedMachine(machine, fit);
  report(1.0, "done");
  return out;
}

}  // namespace km::usecases
