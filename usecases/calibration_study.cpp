#include "usecases/calibration_study.h"

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"
#include "usecases/discovery_json.h"
#include "usecases/effect_calibration.h"

namespace km::usecases {
namespace {

// [PM-600 report] table 2.2 figures of one trace: centre deviation |(X0, Y0)| (absolute mode: the
// machine's centre positioning error against the jig ball), average radial error, circularity.
void AddFigures(nlohmann::json& t, const dbb::DbbTest& test, const std::string& suffix) {
  const auto f = dbb::AnalyzeCircularTest(test);
  t["centre_deviation" + suffix] = std::hypot(f.centre_offset_um[0], f.centre_offset_um[1]);
  t["average_radial_error" + suffix] = f.average_radial_error_um;
}

nlohmann::json CalibrationJson(const hexapod::CalibrationResult& r,
                               const std::vector<hexapod::TestPrediction>& pred,
                               const std::vector<std::string>& names,
                               const std::vector<dbb::DbbTest>& tests) {
  nlohmann::json j;
  j["method"] = hexapod::ToString(r.method);
  j["parameters"] = KinematicJson(r.parameters_um);
  j["parameter_uncertainty_um"] = KinematicJson(r.uncertainty_um);
  j["fixed_parameters"] = r.fixed_parameters;
  j["tests"] = nlohmann::json::array();
  for (std::size_t i = 0; i < pred.size(); ++i) {
    nlohmann::json t;
    t["test_id"] = pred[i].test_id;
    t["direction"] = dbb::ToString(pred[i].direction);
    if (i < names.size()) t["file"] = names[i];
    t["circularity_before_um"] = pred[i].circularity_before_um;
    t["predicted_circularity_after_um"] = pred[i].predicted_circularity_after_um;
    // [PM-600 report] eq. 4.8 and table 2.2/5.1 give these figures in bar units (the bar's own
    // reading); a cone test's tool-path figures are the factor times them.
    t["deviation_units"] = dbb::ToString(dbb::DeviationUnits::kBar);
    if (i < tests.size()) t["bar_to_tool_path_factor"] = dbb::ToolPathFactor(tests[i]);
    if (i < tests.size() && pred[i].predicted_dr_um.size() == tests[i].dr_um.size()) {
      AddFigures(t, tests[i], "_before_um");
      dbb::DbbTest after = tests[i];
      after.dr_um = pred[i].predicted_dr_um;
      AddFigures(t, after, "_predicted_after_um");
    }
    if (i < r.fixed_balls_mm.size()) {
      const auto& f = r.fixed_balls_mm[i];
      t["fixed_ball_mm"] = {f.x(), f.y(), f.z()};
    }
    j["tests"].push_back(t);
  }
  j["residual_rms_um"] = r.residual_rms_um;
  j["condition_number"] = r.condition_number;
  j["iterations"] = r.iterations;
  j["converged"] = r.converged;
  return j;
}

}  // namespace

std::optional<hexapod::CalibrationMethod> ParseCalibrationMethod(const std::string& text,
                                                                 const std::string& field) {
  if (text.empty()) return std::nullopt;
  if (text == "absolute") return hexapod::CalibrationMethod::kAbsolute;
  if (text == "centre-corrected" || text == "centre_corrected") {
    return hexapod::CalibrationMethod::kCentreCorrected;
  }
  throw InvalidInput("", 0, field, "'" + text + "' is neither absolute nor centre-corrected");
}

CalibrationOutcome RunCalibrationStudy(const CalibrationStudy& study, const ProgressFn& progress) {
  auto report = [&](double f, const std::string& stage) {
    if (progress) progress(f, stage);
  };
  if (study.tests.empty()) throw InvalidInput("", 0, "tests", "no DBB test given");
  bool all_have_ball = true;
  for (const auto& t : study.tests) all_have_ball = all_have_ball && t.fixed_ball_mm.has_value();
  hexapod::CalibrationOptions options;
  options.method =
      study.method.value_or(all_have_ball ? hexapod::CalibrationMethod::kAbsolute
                                          : hexapod::CalibrationMethod::kCentreCorrected);
  options.max_samples_per_test = study.max_samples_per_test;
  for (std::size_t i = 0; i < study.tests.size(); ++i) {
    const auto& t = study.tests[i];
    const std::string name = i < study.names.size() ? study.names[i] : t.test_id;
    if (!t.tool_length_mm) {
      throw InvalidInput(name, 0, "tool_length_mm", "hexapod calibration needs the tool length");
    }
    if (options.method == hexapod::CalibrationMethod::kAbsolute && !t.fixed_ball_mm) {
      throw InvalidInput(name, 0, "fixed_ball_mm",
                         "absolute calibration needs the measured fixed-ball position");
    }
  }
  if (!study.effects.empty() || !study.machine.effects.empty()) {
    if (study.reduction_min_tests > 0)
      throw InvalidInput("", 0, "reduction_min_tests",
                         "the reduction study is available for the plain calibration only");
    return RunEffectCalibration(study, progress);
  }
  report(0.05, "calibrating");
  const auto result = hexapod::Calibrate(study.machine.geometry, study.tests, options);
  report(0.6, "predicting the traces after calibration");
  const auto pred = hexapod::PredictAfterCalibration(study.machine.geometry, result.calibrated,
                                                     study.tests, result.fixed_balls_mm);
  CalibrationOutcome out;
  out.report = CalibrationJson(result, pred, study.names, study.tests);
  out.calibrated = study.machine;
  out.calibrated.geometry = result.calibrated;
  if (study.reduction_min_tests > 0) {  // [PM-600 report] §5.2.3
    report(0.7, "test-set reduction study");
    nlohmann::json steps = nlohmann::json::array();
    // Each of its calibrations is reported: a job's progress, and where a cancelled job stops.
    const auto each = [&](double done, const std::string& stage) {
      report(0.7 + 0.29 * done, "test-set reduction study: " + stage);
    };
    for (const auto& st : hexapod::TestSetReductionStudy(
             study.machine.geometry, study.tests, options, study.reduction_min_tests, each)) {
      steps.push_back({{"tests_kept", st.groups_kept},
                       {"kept_test_ids", st.kept_test_ids},
                       {"dropped_test_id", st.dropped_test_id},
                       {"mean_predicted_circularity_um", st.mean_predicted_circularity_um},
                       {"max_predicted_circularity_um", st.max_predicted_circularity_um},
                       {"condition_number", st.condition_number}});
    }
    out.report["reduction_study"] = steps;
  }
  report(1.0, "done");
  return out;
}

}  // namespace km::usecases
