// `kinemetric simulate dbb --machine M.json [--plan table2.1|verification] [--out DIR]
//  [--effects "NAME[:P=V,...];..."] [--tools L1,L2] [--start ISO] [--interval-s S]
//  [--noise-um S] [--seed N] [--perturb-base-mm B] [--perturb-strut-mm S] [--absolute]
//  [--samples N] [--single-direction] [--seat-error-um S] [--write-truth TRUE.json] [--json]`:
// synthetic DBB files (docs/formats.md §1.1) of a "real" hexapod whose base joints and strut
// offsets differ from the machine file by seeded uniform errors (analysis/sim/hexapod_dbb_sim.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "analysis/hexapod/calibration.h"
#include "analysis/sim/hexapod_dbb_sim.h"
#include "cli/command.h"
#include "ingest/dbb_writer.h"
#include "ingest/iso8601.h"
#include "ingest/machine_json.h"

namespace km::cli {
namespace {

// `--tools L1,L2,…`: the plan's rows split into as many consecutive groups, one tool each.
nlohmann::json EffectsJson(const std::vector<hexapod::ActiveEffect>& effects) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& a : effects) {
    nlohmann::json p = nlohmann::json::object();
    for (const auto& q : a.params) p[q.name] = q.value;
    list.push_back({{"effect", a.effect->Name()}, {"parameters", p}});
  }
  return list;
}

// Timestamps: `--start ISO` (default 2026-03-10T08:00:00Z) and `--interval-s S` (default 150)
// between the starts of consecutive tests.
void AssignToolsAndTimes(const Args& args, std::vector<sim::HexapodDbbSpec>& plan) {
  if (const auto tools = args.Get("--tools")) {
    std::vector<double> l;
    std::stringstream ss(*tools);
    std::string item;
    while (std::getline(ss, item, ',')) {
      char* end = nullptr;
      const double v = std::strtod(item.c_str(), &end);
      if (end == item.c_str() || *end != '\0' || !(v >= 0.0 && v <= 2000.0))
        throw InvalidInput("", 0, "--tools", "'" + item + "' is not a tool length in mm");
      l.push_back(v);
    }
    if (l.empty()) throw InvalidInput("", 0, "--tools", "no tool length given");
    std::vector<std::string> ids;
    for (const auto& s : plan)
      if (std::find(ids.begin(), ids.end(), s.test_id) == ids.end()) ids.push_back(s.test_id);
    for (auto& s : plan) {
      const auto pos = std::find(ids.begin(), ids.end(), s.test_id) - ids.begin();
      s.tool_length_mm = l[static_cast<std::size_t>(pos) * l.size() / ids.size()];
    }
  }
  const std::string start = args.Get("--start").value_or("2026-03-10T08:00:00Z");
  const auto t0 = ingest::Iso8601EpochSeconds(start);
  if (!t0) throw InvalidInput("", 0, "--start", "not an ISO 8601 time: '" + start + "'");
  const double interval = args.GetNumber("--interval-s", 150.0);
  if (!(interval >= 0.0 && interval <= 1e6))
    throw InvalidInput("", 0, "--interval-s", "must lie in [0, 1e6] s");
  for (std::size_t i = 0; i < plan.size(); ++i) {
    plan[i].start_time_s = *t0 + interval * static_cast<double>(i);
    plan[i].timestamp = ingest::UtcIso8601FromMicros(
        static_cast<std::int64_t>(std::llround(*plan[i].start_time_s * 1e6)));
  }
}

// `--effects "gravity_deflection:K_stiff2_mm_per_N=1.52e-5;joint_friction:torque_Nm=8.88"`:
// the real machine's effects; parameters not given keep their defaults. `lenient` (the machine
// file's stored effects) skips parameters this plan has no use for.
std::vector<hexapod::ActiveEffect> ParseEffects(const std::string& text,
                                                const std::vector<sim::HexapodDbbSpec>& plan,
                                                const hexapod::MachinePhysics* physics,
                                                bool lenient) {
  std::vector<hexapod::ActiveEffect> out;
  if (text.empty()) return out;
  hexapod::EffectSetup setup;
  setup.physics = physics;
  setup.all_timed = true;
  for (const auto& s : plan)
    if (std::find(setup.tool_lengths_mm.begin(), setup.tool_lengths_mm.end(), s.tool_length_mm) ==
        setup.tool_lengths_mm.end())
      setup.tool_lengths_mm.push_back(s.tool_length_mm);
  std::sort(setup.tool_lengths_mm.begin(), setup.tool_lengths_mm.end());
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ';')) {
    const auto colon = item.find(':');
    const std::string name = item.substr(0, colon);
    const auto* e = hexapod::FindHexapodEffect(name);
    if (!e)
      throw InvalidInput("", 0, "--effects",
                         "'" + name + "' is not one of " + hexapod::HexapodEffectNames());
    hexapod::ActiveEffect a{e, e->Parameters(setup)};
    if (a.params.empty())
      throw InvalidInput("", 0, "--effects", name + " needs the machine's gravity block");
    std::stringstream ps(colon == std::string::npos ? "" : item.substr(colon + 1));
    std::string kv;
    while (std::getline(ps, kv, ',')) {
      const auto eq = kv.find('=');
      char* end = nullptr;
      const std::string key = kv.substr(0, eq);
      const double v = eq == std::string::npos ? 0.0 : std::strtod(kv.c_str() + eq + 1, &end);
      auto it = std::find_if(a.params.begin(), a.params.end(),
                             [&](const auto& p) { return p.name == key; });
      if (lenient && it == a.params.end()) continue;  // e.g. a tool this plan does not use
      if (eq == std::string::npos || end == kv.c_str() + eq + 1 || *end != '\0' ||
          it == a.params.end() || !(v >= it->lower && v <= it->upper))
        throw InvalidInput("", 0, "--effects", "bad parameter '" + kv + "' of " + name);
      it->value = v;
    }
    out.push_back(std::move(a));
  }
  return out;
}

// The effects of the machine file's model ("effects" block) in the --effects syntax: a machine
// saved by a discovery is simulated with what was discovered.
std::string StoredEffects(const ingest::MachineDefinition& m) {
  std::string text;
  for (const auto& e : m.effects) {
    text += (text.empty() ? "" : ";") + e.effect;
    for (std::size_t i = 0; i < e.parameters.size(); ++i) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "%s%s=%.17g", i == 0 ? ":" : ",",
                    e.parameters[i].first.c_str(), e.parameters[i].second);
      text += buf;
    }
  }
  return text;
}

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
  AssignToolsAndTimes(args, plan);
  sim::HexapodDbbSimOptions opt;
  opt.physics = machine.physics ? &*machine.physics : nullptr;
  const auto given = args.Get("--effects");
  opt.effects = ParseEffects(given.value_or(StoredEffects(machine)), plan, opt.physics,
                             /*lenient=*/!given);
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
      {"effects", EffectsJson(opt.effects)},
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
               "[--effects \"NAME[:P=V,...];...\"] [--tools L1,L2] [--start ISO] [--interval-s S] "
               "[--json]",
               {"--machine", "--plan", "--out", "--noise-um", "--seed", "--perturb-base-mm",
                "--perturb-strut-mm", "--samples", "--seat-error-um", "--write-truth", "--effects",
                "--tools", "--start", "--interval-s"},
               RunSimulateDbb);

}  // namespace
}  // namespace km::cli
