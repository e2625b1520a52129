// `kinemetric hexapod calibrate --machine M.json FILE… [--method absolute|centre-corrected]
//  [--write-machine OUT.json] [--max-samples-per-test N] [--reduction-study MIN_TESTS]
//  [--effects gravity_deflection,joint_friction,…] [--json]`
//  (docs/formats.md §3): 24-parameter kinematic calibration of a
// hexapod from DBB files ([PM-600 report] §2.2–2.3), with the post-calibration prediction of every
// trace ([PM-600 report] eq. 5.2). Parsing in ingest/, numerics in analysis/hexapod, JSON mapping
// here.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <ostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "analysis/hexapod/calibration.h"
#include "cli/command.h"
#include "ingest/file_formats.h"
#include "ingest/machine_json.h"
#include "usecases/calibration_study.h"

namespace km::cli {
namespace {

int RunHexapodCalibrate(const Args& args, std::ostream& out) {
  const auto machine_path = args.Get("--machine");
  if (!machine_path || machine_path->empty()) {
    throw InvalidInput("", 0, "--machine", "the hexapod machine file is required");
  }
  if (args.positional.empty()) throw InvalidInput("", 0, "FILE", "no DBB file given");
  const auto machine = ingest::ParseHexapodMachineJson(ReadFileBytes(*machine_path), *machine_path);
  usecases::CalibrationStudy study;
  study.machine = machine;
  for (const auto& path : args.positional) {
    study.tests.push_back(ingest::ReadDbb(ReadFileBytes(path), path));
    study.names.push_back(path);
  }
  if (const auto m = args.Get("--method"))
    study.method = usecases::ParseCalibrationMethod(*m, "--method");
  const double max_samples = args.GetNumber("--max-samples-per-test", 0);
  if (!(max_samples >= 0 && max_samples <= 1e7) || max_samples != std::floor(max_samples)) {
    throw InvalidInput("", 0, "--max-samples-per-test", "must be a non-negative integer");
  }
  study.max_samples_per_test = static_cast<int>(max_samples);
  if (args.Has("--reduction-study")) {  // [PM-600 report] §5.2.3
    const double min_groups = args.GetNumber("--reduction-study", 8);
    if (!(min_groups >= 1 && min_groups <= 1000) || min_groups != std::floor(min_groups)) {
      throw InvalidInput("", 0, "--reduction-study", "must be a positive integer (minimum tests)");
    }
    study.reduction_min_tests = static_cast<int>(min_groups);
  }
  if (const auto e = args.Get("--effects")) {  // [PM-600 report] eq. 5.3, [Joint patent] 15–20
    std::stringstream ss(*e);
    std::string name;
    while (std::getline(ss, name, ','))
      if (!name.empty()) study.effects.push_back(name);
  }
  const auto outcome = usecases::RunCalibrationStudy(study);
  const auto& report = outcome.report;
  if (const auto w = args.Get("--write-machine")) {
    std::ofstream f(*w, std::ios::binary);
    f << ingest::WriteMachineJson(outcome.calibrated);
    if (!f) throw InvalidInput(*w, 0, "--write-machine", "cannot write the file");
  }
  if (args.json) {
    out << report.dump(2) << "\n";
    return 0;
  }
  char line[256];
  std::snprintf(line, sizeof line, "method %s, residual rms %.3f um, condition number %.1f\n",
                report["method"].get<std::string>().c_str(),
                report["residual_rms_um"].get<double>(), report["condition_number"].get<double>());
  out << line;
  const auto& p = report["parameters"];
  const auto& u = report["parameter_uncertainty_um"];
  for (int j = 0; j < 6; ++j) {
    std::snprintf(line, sizeof line, "  strut %d offset %10.3f +- %.3f um\n", j + 1,
                  p["strut_offset_um"][j].get<double>(), u["strut_offset_um"][j].get<double>());
    out << line;
  }
  for (int j = 0; j < 6; ++j) {
    std::snprintf(line, sizeof line, "  base joint %d offset %9.3f %9.3f %9.3f um\n", j + 1,
                  p["base_joint_offset_um"][j][0].get<double>(),
                  p["base_joint_offset_um"][j][1].get<double>(),
                  p["base_joint_offset_um"][j][2].get<double>());
    out << line;
  }
  if (!report["fixed_parameters"].empty()) {
    out << "  fixed (unobservable): " << report["fixed_parameters"].dump() << "\n";
  }
  for (const auto& t : report["tests"]) {
    std::snprintf(line, sizeof line, "  test %-12s %-4s circularity %8.3f -> predicted %8.3f um\n",
                  t["test_id"].get<std::string>().c_str(),
                  t["direction"].get<std::string>().c_str(),
                  t["circularity_before_um"].get<double>(),
                  t["predicted_circularity_after_um"].get<double>());
    out << line;
  }
  return 0;
}

KM_CLI_COMMAND("hexapod calibrate",
               "--machine M.json FILE... [--method absolute|centre-corrected] "
               "[--write-machine OUT.json] [--max-samples-per-test N] "
               "[--reduction-study MIN_TESTS] [--effects NAME,NAME] [--json]",
               {"--machine", "--method", "--write-machine", "--max-samples-per-test",
                "--reduction-study", "--effects"},
               RunHexapodCalibrate);

}  // namespace
}  // namespace km::cli
