// `kinemetric form straightness FILE…`, `form flatness FILE`, `form parallelism FILE`
// (docs/formats.md §3). Parsing in ingest/form_parsers, numerics in analysis/form, JSON mapping in
// report/form_report.
#include <cmath>
#include <map>
#include <numbers>
#include <ostream>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "usecases/form_report.h"

namespace km::cli {
using usecases::FlatnessFileToJson;
using usecases::FormResultToJson;
using usecases::ParallelismFileToJson;
using usecases::StraightnessFilesToJson;

namespace {

void PrintStraightness(std::ostream& out, const nlohmann::json& j) {
  out << "  straightness (least squares) " << j["straightness_lsq_um"].get<double>() << " um\n"
      << "  straightness (minimum zone)  " << j["straightness_min_zone_um"].get<double>() << " um\n"
      << "  straightness (end points)    " << j["straightness_end_point_um"].get<double>()
      << " um\n"
      << "  slope (least squares)        " << j["slope_um_per_m"].get<double>() << " um/m\n";
  for (const auto& c : j["periodic"]) {
    out << "  periodic: period " << c["period_mm"].get<double>() << " mm, amplitude "
        << c["amplitude_um"].get<double>() << " um\n";
  }
  if (j.contains("reversal")) {
    const auto& r = j["reversal"];
    out << "  reversal pair " << r["pair_id"].get<std::string>() << ": machine "
        << r["machine_straightness_lsq_um"].get<double>() << " um, artefact "
        << r["artefact_straightness_lsq_um"].get<double>() << " um (least squares, set-up "
        << r["reversal_setup"].get<std::string>() << ")\n";
  }
}

form::StraightnessOptions OptionsFrom(const Args& args) {
  form::StraightnessOptions o;
  o.periodic.min_period_mm = args.GetNumber("--min-period-mm", 0.0);
  o.periodic.max_period_mm = args.GetNumber("--max-period-mm", 0.0);
  o.periodic.false_alarm_probability = args.GetNumber("--false-alarm", 1e-3);
  try {
    o.Check();
  } catch (const InvalidInput& e) {
    const std::map<std::string, std::string> option_of{
        {"min_period_mm", "--min-period-mm"},
        {"max_period_mm", "--max-period-mm"},
        {"false_alarm_probability", "--false-alarm"}};
    const auto it = option_of.find(e.field());
    throw InvalidInput("", 0, it != option_of.end() ? it->second : e.field(), e.reason());
  }
  return o;
}

int RunStraightness(const Args& args, std::ostream& out) {
  if (args.positional.empty()) {
    throw InvalidInput("", 0, "FILE", "give one or more straightness files");
  }
  const form::StraightnessOptions options = OptionsFrom(args);
  std::vector<ingest::StraightnessFile> files;
  for (const auto& path : args.positional) {
    files.push_back(ingest::ParseStraightnessFile(ReadFileBytes(path), path));
  }
  const nlohmann::json j = StraightnessFilesToJson(files, options);
  if (args.json) {
    out << j.dump(2) << "\n";
    return 0;
  }
  if (files.size() == 1) {
    out << files.front().file << "\n";
    PrintStraightness(out, j);
  } else {
    for (const auto& p : j["profiles"]) {
      out << p["file"].get<std::string>() << "\n";
      PrintStraightness(out, p);
    }
  }
  return 0;
}

std::string SingleFile(const Args& args, const char* what) {
  if (args.positional.size() != 1) {
    throw InvalidInput("", 0, "FILE", std::string("give exactly one ") + what + " file");
  }
  return args.positional.front();
}

int RunFlatness(const Args& args, std::ostream& out) {
  const std::string path = SingleFile(args, "flatness");
  const nlohmann::json j = FlatnessFileToJson(ingest::ParseFlatnessFile(ReadFileBytes(path), path));
  if (args.json) {
    out << j.dump(2) << "\n";
    return 0;
  }
  out << path << "\n"
      << "  flatness (least squares) " << j["flatness_lsq_um"].get<double>() << " um\n"
      << "  flatness (minimum zone)  " << j["flatness_min_zone_um"].get<double>() << " um\n"
      << "  range (to the datum)     " << j["range_um"].get<double>() << " um\n"
      << "  plane slopes             " << j["plane"]["slope_x_um_per_m"].get<double>() << ", "
      << j["plane"]["slope_y_um_per_m"].get<double>() << " um/m\n";
  return 0;
}

int RunParallelism(const Args& args, std::ostream& out) {
  const std::string path = SingleFile(args, "parallelism");
  const nlohmann::json j =
      ParallelismFileToJson(ingest::ParseParallelismFile(ReadFileBytes(path), path));
  if (args.json) {
    out << j.dump(2) << "\n";
    return 0;
  }
  out << path << "\n"
      << "  parallelism " << j["parallelism_um"].get<double>() << " um over "
      << j["length_mm"].get<double>() << " mm\n"
      << "  slope (least squares) " << j["slope_um_per_m"].get<double>() << " um/m\n";
  return 0;
}

}  // namespace

KM_CLI_COMMAND("form straightness",
               "FILE... [--json] [--min-period-mm P] [--max-period-mm P] [--false-alarm F]",
               {"--min-period-mm", "--max-period-mm", "--false-alarm"}, RunStraightness);
KM_CLI_COMMAND("form flatness", "FILE [--json]", {}, RunFlatness);
KM_CLI_COMMAND("form parallelism", "FILE [--json]", {}, RunParallelism);

}  // namespace km::cli
