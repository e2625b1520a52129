// `kinemetric servo identify | force | joints | feed-drive` (docs/formats.md §3.10–3.13):
// servo loads of a hexapod or a serial feed drive. Parsing in ingest/servo_parser, numerics in
// analysis/servo, JSON mapping in report/servo_report (shared with the service).
#include <cstdio>
#include <fstream>
#include <map>
#include <ostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "ingest/file_formats.h"
#include "ingest/machine_json.h"
#include "ingest/servo_parser.h"
#include "usecases/servo_report.h"

namespace km::cli {
namespace {

using nlohmann::json;

ingest::MachineDefinition Machine(const Args& args) {
  const auto path = args.Get("--machine");
  if (!path || path->empty()) {
    throw InvalidInput("", 0, "--machine", "the hexapod machine file is required");
  }
  return ingest::ParseHexapodMachineJson(ReadFileBytes(*path), *path);
}

std::vector<servo::ServoFile> Files(const Args& args, const std::string& machine_id, bool hexapod) {
  if (args.positional.empty()) throw InvalidInput("", 0, "FILE", "no servo-load file given");
  std::vector<servo::ServoFile> files;
  for (const auto& path : args.positional) {
    files.push_back(ingest::ParseServoFile(ReadFileBytes(path), path));
    const auto& f = files.back();
    if (f.hexapod != hexapod) {
      throw InvalidInput(path, 0, hexapod ? "axis" : "f1",
                         hexapod ? "a feed-drive record; this command needs hexapod strut loads"
                                 : "a hexapod record; this command needs a feed drive");
    }
    if (!machine_id.empty() && f.machine_id != machine_id) {
      throw InvalidInput(path, 0, "machine_id",
                         "'" + f.machine_id + "' is not the machine '" + machine_id + "'");
    }
  }
  return files;
}

// A machine without gravity / friction blocks: g only, every mass and friction zero.
hexapod::MachinePhysics PhysicsOrDefault(const ingest::MachineDefinition& m) {
  return m.physics ? *m.physics : hexapod::MachinePhysics{};
}

int Print(const Args& args, std::ostream& out, const json& j, const std::string& text) {
  out << (args.json ? j.dump(2) + "\n" : text);
  return 0;
}

int RunIdentify(const Args& args, std::ostream& out) {
  const auto machine = Machine(args);
  const auto files = Files(args, machine.machine_id, true);
  servo::IdentifyOptions o;
  o.min_rate_fraction = args.GetNumber("--min-rate-fraction", o.min_rate_fraction);
  o.reversal_skip_mm = args.GetNumber("--reversal-skip-mm", o.reversal_skip_mm);
  o.inertia = !args.Has("--no-inertia");
  const auto r = servo::IdentifyLoads(machine.geometry, PhysicsOrDefault(machine), files, o);
  const json j = usecases::ServoIdentifyJson(machine.machine_id, files, r);
  if (const auto w = args.Get("--write-machine")) {
    std::ofstream f(*w, std::ios::binary);
    f << usecases::MachineWithIdentified(machine, r);
    if (!f) throw InvalidInput(*w, 0, "--write-machine", "cannot write the file");
  }
  std::ostringstream t;
  const auto& id = j["identified"];
  const auto& u = j["uncertainty"];
  t << "platform mass " << id["platform_mass_kg"] << " +- " << u["platform_mass_kg"] << " kg\n"
    << "platform centre of gravity " << id["platform_cog_mm"] << " +- " << u["platform_cog_mm"]
    << " mm\n"
    << "strut equivalent mass " << id["strut_equivalent_mass_kg"] << " kg, motor mass "
    << id["motor_mass_kg"] << " kg\n"
    << "ball-screw friction " << id["screw_friction_N"] << " N\n"
    << "base-joint torque " << id["base_joint_torque_Nm"] << " N m + "
    << id["base_joint_torque_per_N_m"] << " m x load\n"
    << "residual rms " << j["residual_rms_N"] << " N, condition number " << j["condition_number"]
    << "\n";
  if (!j["fixed"].empty()) t << "held at the machine's value: " << j["fixed"] << "\n";
  return Print(args, out, j, t.str());
}

int RunForce(const Args& args, std::ostream& out) {
  const auto machine = Machine(args);
  if (!machine.physics) {
    throw InvalidInput(*args.Get("--machine"), 0, "gravity",
                       "the machine has no gravity and friction blocks (servo identify "
                       "--write-machine writes them)");
  }
  if (args.positional.size() != 1) throw InvalidInput("", 0, "FILE", "give exactly one file");
  const auto files = Files(args, machine.machine_id, true);
  servo::ForceOptions o = usecases::ForceOptionsOf(machine);
  if (args.Has("--joint-ramp-mm")) o.joint_ramp_mm = args.GetNumber("--joint-ramp-mm", 0.0);
  if (args.Has("--screw-ramp-mm")) o.screw_ramp_mm = args.GetNumber("--screw-ramp-mm", 0.0);
  if (args.Has("--noise-N")) {
    std::array<double, 6> n{};
    n.fill(args.GetNumber("--noise-N", 0.0));
    o.strut_noise_N = n;
  }
  const auto f = servo::EstimateExternalForce(machine.geometry, *machine.physics, files[0], o);
  const json j = usecases::ServoForceJson(machine.machine_id, files[0], f);
  std::ostringstream t;
  t << files[0].file << ": " << f.t_s.size() << " samples, mean external force "
    << j["mean_force_N"] << " +- " << j["mean_sigma_N"] << " N\n";
  return Print(args, out, j, t.str());
}

std::array<double, 6> SixNumbers(const std::string& text, const std::string& option) {
  const auto v = ingest::ParseNumberList(text);
  std::array<double, 6> out{};
  if (v && v->size() == 1) out.fill((*v)[0]);
  if (v && v->size() == 6) std::copy(v->begin(), v->end(), out.begin());
  if (!v || (v->size() != 1 && v->size() != 6)) {
    throw InvalidInput("", 0, option, "one number or six, comma-separated");
  }
  return out;
}

int RunJoints(const Args& args, std::ostream& out) {
  const auto machine = Machine(args);
  const auto files = Files(args, machine.machine_id, true);
  servo::JointOptions o;
  o.level2_ratio = args.GetNumber("--level2-ratio", o.level2_ratio);
  o.level3_ratio = args.GetNumber("--level3-ratio", o.level3_ratio);
  o.increase_warn = args.GetNumber("--increase-warn", o.increase_warn);
  o.increase_stop = args.GetNumber("--increase-stop", o.increase_stop);
  o.separate_platform_joints = !args.Has("--no-split");
  if (const auto r = args.Get("--reference-Nm")) o.reference_Nm = SixNumbers(*r, "--reference-Nm");
  if (const auto p = args.Get("--previous")) {
    o.previous_Nm = usecases::PreviousResistances(ReadFileBytes(*p), *p);
  }
  const auto r =
      servo::EstimateJointResistance(machine.geometry, PhysicsOrDefault(machine), files, o);
  const json j = usecases::ServoJointsJson(machine.machine_id, r, o);
  std::ostringstream t;
  for (const auto& leg : r.legs) t << "level " << leg.level << "  " << leg.evidence << "\n";
  t << "worst level " << r.level << " (reference: " << r.reference_source << ")\n";
  return Print(args, out, j, t.str());
}

int RunFeedDrive(const Args& args, std::ostream& out) {
  const auto files = Files(args, "", false);
  servo::FeedDriveOptions o;
  if (args.Has("--radius-mm")) o.radius_mm = args.GetNumber("--radius-mm", 0.0);
  if (args.Has("--feed-mm-min")) o.feed_mm_min = args.GetNumber("--feed-mm-min", 0.0);
  if (args.Has("--kp-per-s")) o.kp_per_s = args.GetNumber("--kp-per-s", 0.0);
  std::vector<std::string> axes;
  if (const auto a = args.Get("--axis")) {
    axes.push_back(*a);
  } else {
    for (const auto& tr : files.front().axes) axes.push_back(tr.axis);
  }
  std::vector<const servo::ServoFile*> ptr;
  for (const auto& f : files) ptr.push_back(&f);
  std::vector<servo::FeedDriveResult> results;
  for (const auto& a : axes) results.push_back(servo::AnalyzeFeedDrive(ptr, a, o));
  json j = usecases::ServoFeedDriveJson(files.front().machine_id, results);
  if (const auto dbb = args.Get("--dbb")) {  // DBB tests of the machine, comma-separated
    std::vector<dbb::DbbTest> tests;
    std::vector<std::string> names;
    std::stringstream ss(*dbb);
    for (std::string path; std::getline(ss, path, ',');) {
      if (path.empty()) continue;
      tests.push_back(ingest::ReadDbb(ReadFileBytes(path), path));
      names.push_back(path);
    }
    j["dbb_comparison"] =
        usecases::DbbStickComparisonJson(tests, names, results.front(), o.kp_per_s);
  }
  std::ostringstream t;
  for (const auto& a : j["axes"]) {
    t << "axis " << a["axis"].get<std::string>() << ": Coulomb " << a["coulomb_N"] << " N, viscous "
      << a["viscous_N_s_per_mm"] << " N s/mm, ripple " << a["ripple"] << ", LuGre " << a["lugre"]
      << ", stick motion " << a["stick_motion_um"] << " um\n";
  }
  return Print(args, out, j, t.str());
}

KM_CLI_COMMAND("servo identify",
               "--machine M.json FILE... [--write-machine OUT.json] [--min-rate-fraction F] "
               "[--reversal-skip-mm D] [--no-inertia] [--json]",
               {"--machine", "--write-machine", "--min-rate-fraction", "--reversal-skip-mm"},
               RunIdentify);
KM_CLI_COMMAND("servo force",
               "--machine M.json FILE [--joint-ramp-mm L] [--screw-ramp-mm L] [--noise-N S] "
               "[--json]",
               {"--machine", "--noise-N", "--joint-ramp-mm", "--screw-ramp-mm"}, RunForce);
KM_CLI_COMMAND("servo joints",
               "--machine M.json FILE... [--previous RESULT.json] [--level2-ratio R] "
               "[--level3-ratio R] [--increase-warn F] [--increase-stop F] [--reference-Nm T] "
               "[--no-split] [--json]",
               {"--machine", "--previous", "--level2-ratio", "--level3-ratio", "--increase-warn",
                "--increase-stop", "--reference-Nm"},
               RunJoints);
KM_CLI_COMMAND("servo feed-drive",
               "FILE... [--axis X] [--radius-mm R --feed-mm-min F --kp-per-s K] "
               "[--dbb DBB1,DBB2] [--json]",
               {"--axis", "--radius-mm", "--feed-mm-min", "--kp-per-s", "--dbb"}, RunFeedDrive);

}  // namespace
}  // namespace km::cli
