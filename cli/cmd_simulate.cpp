// `kinemetric simulate dbb --machine M.json [--plan table2.1|verification] [--out DIR]
//  [--noise-um S] [--seed N] [--perturb-base-mm B] [--perturb-strut-mm S] [--absolute]
//  [--samples N] [--single-direction] [--seat-error-um S] [--write-truth TRUE.json] [--json]`:
// synthetic DBB files (contract §1.1) of a "real" hexapod whose base joints and strut offsets
// differ from the machine file by seeded uniform errors (analysis/sim/hexapod_dbb_sim.h).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <ostream>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "analysis/hexapod/calibration.h"
#include "analysis/sim/hexapod_dbb_sim.h"
#include "cli/command.h"
#include "ingest/dbb_writer.h"
#include "ingest/machine_json.h"

namespace km::cli {
namespace {

int RunSimulateDbb(const Args& args, std::ostream& out) {
  const auto machine_path = args.Get("--machine");
  if (!machine_path || machine_path->empty()) {
    throw InvalidInput("", 0, "--machine", "the hexapod machine file is required");
  }
  const auto machine = ingest::ParseHexapodMachineJson(ReadFileBytes(*machine_path), *machine_path);
  const std::string plan_name = args.Get("--plan").value_or("table2.1");
  const double samples = args.GetNumber("--samples", 720);
  if (!(samples >= 8 && samples <= 100000) || samples != std::floor(samples)) {
    throw InvalidInput("", 0, "--samples", "must be an integer between 8 and 100000");
  }
  const bool both = !args.Has("--single-direction");
  std::vector<sim::HexapodDbbSpec> plan;
  if (plan_name == "table2.1") {
    plan = sim::Table21Plan(static_cast<int>(samples), both);
  } else if (plan_name == "verification") {
    plan = sim::VerificationPlan(static_cast<int>(samples));
  } else {
    throw InvalidInput("", 0, "--plan", "'" + plan_name + "' is neither table2.1 nor verification");
  }
  const double noise = args.GetNumber("--noise-um", 0.3);
  const double seat = args.GetNumber("--seat-error-um", 0.0);
  if (!(seat >= 0.0 && seat <= 1000.0))
    throw InvalidInput("", 0, "--seat-error-um", "must lie in [0, 1000]");
  const double base = args.GetNumber("--perturb-base-mm", 0.3);
  const double strut = args.GetNumber("--perturb-strut-mm", 0.1);
  const double seed = args.GetNumber("--seed", 1);
  if (!(noise >= 0.0)) throw InvalidInput("", 0, "--noise-um", "must not be negative");
  if (!(base >= 0.0 && base <= 5.0))
    throw InvalidInput("", 0, "--perturb-base-mm", "must lie in [0, 5]");
  if (!(strut >= 0.0 && strut <= 5.0))
    throw InvalidInput("", 0, "--perturb-strut-mm", "must lie in [0, 5]");
  if (!(seed >= 0 && seed <= 4294967295.0) || seed != std::floor(seed)) {
    throw InvalidInput("", 0, "--seed", "must be a non-negative integer");
  }
  const auto seed_u = static_cast<std::uint32_t>(seed);
  const auto truth = sim::PerturbGeometry(machine.geometry, base, strut, seed_u);
  sim::HexapodDbbSimOptions opt;
  opt.absolute = args.Has("--absolute");
  opt.noise_um = noise;
  opt.fixed_ball_error_um = seat;
  opt.seed = seed_u + 1;
  opt.machine_id = machine.machine_id;
  const auto tests = sim::SimulateHexapodDbbPlan(machine.geometry, truth, plan, opt);

  const std::filesystem::path dir = args.Get("--out").value_or(".");
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InvalidInput(dir.string(), 0, "--out", "cannot create the directory");
  nlohmann::json files = nlohmann::json::array();
  for (const auto& t : tests) {
    const auto path = dir / ("dbb_" + t.test_id + "_" + dbb::ToString(t.direction) + ".txt");
    std::ofstream f(path, std::ios::binary);
    f << ingest::WriteDbb(t);
    if (!f) throw InvalidInput(path.string(), 0, "--out", "cannot write the file");
    files.push_back(path.string());
  }
  if (const auto w = args.Get("--write-truth")) {
    auto m = machine;
    m.geometry = truth;
    std::ofstream f(*w, std::ios::binary);
    f << ingest::WriteMachineJson(m);
    if (!f) throw InvalidInput(*w, 0, "--write-truth", "cannot write the file");
  }
  const auto k = hexapod::ParameterDifference(machine.geometry, truth);
  nlohmann::json strut_j = nlohmann::json::array(), base_j = nlohmann::json::array();
  for (int j = 0; j < 6; ++j) {
    strut_j.push_back(k[j]);
    base_j.push_back({k[6 + 3 * j], k[7 + 3 * j], k[8 + 3 * j]});
  }
  nlohmann::json report = {
      {"machine_id", machine.machine_id},
      {"plan", plan_name},
      {"mode", opt.absolute ? "absolute" : "centre_corrected"},
      {"noise_um", noise},
      {"seed", seed_u},
      {"samples_per_turn", static_cast<int>(samples)},
      {"true_parameters", {{"strut_offset_um", strut_j}, {"base_joint_offset_um", base_j}}},
      {"files", files}};
  if (args.json) {
    out << report.dump(2) << "\n";
  } else {
    out << "wrote " << files.size() << " DBB files to " << dir.string() << "\n";
  }
  return 0;
}

KM_CLI_COMMAND("simulate dbb",
               "--machine M.json [--plan table2.1|verification] [--out DIR] [--noise-um S] "
               "[--seed N] [--perturb-base-mm B] [--perturb-strut-mm S] [--absolute] "
               "[--samples N] [--single-direction] [--seat-error-um S] [--write-truth TRUE.json] "
               "[--json]",
               {"--machine", "--plan", "--out", "--noise-um", "--seed", "--perturb-base-mm",
                "--perturb-strut-mm", "--samples", "--seat-error-um", "--write-truth"},
               RunSimulateDbb);

}  // namespace
}  // namespace km::cli
