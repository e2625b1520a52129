// `kinemetric hexapod calibrate --machine M.json FILE… [--method absolute|centre-corrected]
//  [--write-machine OUT.json] [--max-samples-per-test N] [--reduction-study MIN_TESTS] [--json]`
//  (contract §3): 24-parameter kinematic calibration of a
// hexapod from DBB files (seed 000 §2.2–2.3), with the post-calibration prediction of every
// trace (seed 000 eq. 5.2). Parsing in ingest/, numerics in analysis/hexapod, JSON mapping here.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <ostream>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "analysis/hexapod/calibration.h"
#include "cli/command.h"
#include "ingest/dbb_parser.h"
#include "ingest/machine_json.h"

namespace km::cli {
namespace {

nlohmann::json ParameterJson(const hexapod::ParameterVector& k) {
  nlohmann::json strut = nlohmann::json::array(), base = nlohmann::json::array();
  for (int j = 0; j < 6; ++j) {
    strut.push_back(k[j]);
    base.push_back({k[6 + 3 * j], k[7 + 3 * j], k[8 + 3 * j]});
  }
  return {{"strut_offset_um", strut}, {"base_joint_offset_um", base}};
}

// The contract §3 object of one calibration (plus extra keys).
nlohmann::json CalibrationJson(const hexapod::CalibrationResult& r,
                               const std::vector<hexapod::TestPrediction>& pred,
                               const std::vector<std::string>& files) {
  nlohmann::json j;
  j["method"] = hexapod::ToString(r.method);
  j["parameters"] = ParameterJson(r.parameters_um);
  j["parameter_uncertainty_um"] = ParameterJson(r.uncertainty_um);
  j["fixed_parameters"] = r.fixed_parameters;
  j["tests"] = nlohmann::json::array();
  for (std::size_t i = 0; i < pred.size(); ++i) {
    nlohmann::json t;
    t["test_id"] = pred[i].test_id;
    t["direction"] = dbb::ToString(pred[i].direction);
    if (i < files.size()) t["file"] = files[i];
    t["circularity_before_um"] = pred[i].circularity_before_um;
    t["predicted_circularity_after_um"] = pred[i].predicted_circularity_after_um;
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

int RunHexapodCalibrate(const Args& args, std::ostream& out) {
  const auto machine_path = args.Get("--machine");
  if (!machine_path || machine_path->empty()) {
    throw InvalidInput("", 0, "--machine", "the hexapod machine file is required");
  }
  if (args.positional.empty()) throw InvalidInput("", 0, "FILE", "no DBB file given");
  const auto machine = ingest::ParseHexapodMachineJson(ReadFileBytes(*machine_path), *machine_path);
  std::vector<dbb::DbbTest> tests;
  bool all_have_ball = true;
  for (const auto& path : args.positional) {
    tests.push_back(ingest::ParseDbb(ReadFileBytes(path), path));
    all_have_ball = all_have_ball && tests.back().fixed_ball_mm.has_value();
  }
  hexapod::CalibrationOptions options;
  options.method = all_have_ball ? hexapod::CalibrationMethod::kAbsolute
                                 : hexapod::CalibrationMethod::kCentreCorrected;
  if (const auto m = args.Get("--method")) {
    if (*m == "absolute") {
      options.method = hexapod::CalibrationMethod::kAbsolute;
    } else if (*m == "centre-corrected" || *m == "centre_corrected") {
      options.method = hexapod::CalibrationMethod::kCentreCorrected;
    } else {
      throw InvalidInput("", 0, "--method",
                         "'" + *m + "' is neither absolute nor centre-corrected");
    }
  }
  const double max_samples = args.GetNumber("--max-samples-per-test", 0);
  if (!(max_samples >= 0 && max_samples <= 1e7) || max_samples != std::floor(max_samples)) {
    throw InvalidInput("", 0, "--max-samples-per-test", "must be a non-negative integer");
  }
  options.max_samples_per_test = static_cast<int>(max_samples);
  // Per-file checks so the message names the file.
  for (std::size_t i = 0; i < tests.size(); ++i) {
    const auto& t = tests[i];
    if (!t.tool_length_mm) {
      throw InvalidInput(args.positional[i], 0, "tool_length_mm",
                         "hexapod calibration needs the tool length");
    }
    if (options.method == hexapod::CalibrationMethod::kAbsolute && !t.fixed_ball_mm) {
      throw InvalidInput(args.positional[i], 0, "fixed_ball_mm",
                         "absolute calibration needs the measured fixed-ball position");
    }
  }
  const auto result = hexapod::Calibrate(machine.geometry, tests, options);
  const auto pred = hexapod::PredictAfterCalibration(machine.geometry, result.calibrated, tests,
                                                     result.fixed_balls_mm);
  if (const auto w = args.Get("--write-machine")) {
    auto calibrated = machine;
    calibrated.geometry = result.calibrated;
    std::ofstream f(*w, std::ios::binary);
    f << ingest::WriteMachineJson(calibrated);
    if (!f) throw InvalidInput(*w, 0, "--write-machine", "cannot write the file");
  }
  auto report = CalibrationJson(result, pred, args.positional);
  if (args.Has("--reduction-study")) {  // seed 000 §5.2.3
    const double min_groups = args.GetNumber("--reduction-study", 8);
    if (!(min_groups >= 1 && min_groups <= 1000) || min_groups != std::floor(min_groups)) {
      throw InvalidInput("", 0, "--reduction-study", "must be a positive integer (minimum tests)");
    }
    nlohmann::json steps = nlohmann::json::array();
    for (const auto& st : hexapod::TestSetReductionStudy(machine.geometry, tests, options,
                                                         static_cast<int>(min_groups))) {
      steps.push_back({{"tests_kept", st.groups_kept},
                       {"kept_test_ids", st.kept_test_ids},
                       {"dropped_test_id", st.dropped_test_id},
                       {"mean_predicted_circularity_um", st.mean_predicted_circularity_um},
                       {"max_predicted_circularity_um", st.max_predicted_circularity_um},
                       {"condition_number", st.condition_number}});
    }
    report["reduction_study"] = steps;
  }
  if (args.json) {
    out << report.dump(2) << "\n";
    return 0;
  }
  char line[256];
  std::snprintf(line, sizeof line, "method %s, residual rms %.3f um, condition number %.1f\n",
                hexapod::ToString(result.method), result.residual_rms_um, result.condition_number);
  out << line;
  for (int i = 0; i < hexapod::kNumKinematicParameters; ++i) {
    std::snprintf(
        line, sizeof line, "  %-28s %10.3f +- %.3f um%s\n", hexapod::ParameterName(i).c_str(),
        result.parameters_um[i], result.uncertainty_um[i],
        std::find(result.fixed_parameter_indices.begin(), result.fixed_parameter_indices.end(),
                  i) != result.fixed_parameter_indices.end()
            ? "  (fixed)"
            : "");
    out << line;
  }
  for (const auto& p : pred) {
    std::snprintf(line, sizeof line, "  test %-12s %-4s circularity %8.3f -> predicted %8.3f um\n",
                  p.test_id.c_str(), dbb::ToString(p.direction), p.circularity_before_um,
                  p.predicted_circularity_after_um);
    out << line;
  }
  return 0;
}

KM_CLI_COMMAND("hexapod calibrate",
               "--machine M.json FILE... [--method absolute|centre-corrected] "
               "[--write-machine OUT.json] [--max-samples-per-test N] "
               "[--reduction-study MIN_TESTS] [--json]",
               {"--machine", "--method", "--write-machine", "--max-samples-per-test",
                "--reduction-study"},
               RunHexapodCalibrate);

}  // namespace
}  // namespace km::cli
