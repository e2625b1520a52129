// kinemetric discover [--machine M.json] FILE… [--json] [--samples N] [--write-machine OUT.json]
//   [--plot DIR]
// Model-gap discovery (usecases/discovery_report.h): serial machines (no --machine, or a machine
// of kind "serial") with the serial effect family, hexapods with the hexapod family whose base
// model is the 24-parameter kinematic calibration.
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "ingest/file_formats.h"
#include "ingest/machine_json.h"
#include "render/polar_plot.h"
#include "usecases/discovery_report.h"

namespace km::cli {
namespace {

void PrintText(const nlohmann::json& r, std::ostream& out) {
  char line[400];
  if (r.contains("base")) {
    std::snprintf(line, sizeof line, "base model (kinematic_parameters): gap %.4f um\n",
                  r["base"]["gap_rms_um"].get<double>());
    out << line;
  }
  std::snprintf(line, sizeof line, "%-4s %-22s %14s %14s %12s\n", "step", "added effect",
                "gap before um", "gap after um", "log10 p");
  out << line;
  int i = 0;
  for (const auto& s : r["steps"]) {
    std::snprintf(line, sizeof line, "%-4d %-22s %14.4f %14.4f %12.1f\n", ++i,
                  s["added_effect"].get<std::string>().c_str(),
                  s["gap_rms_before_um"].get<double>(), s["gap_rms_after_um"].get<double>(),
                  s["evidence"]["log10_p_value"].get<double>());
    out << line;
    if (s["evidence"].contains("sentence"))
      out << "     " << s["evidence"]["sentence"].get<std::string>() << "\n";
  }
  out << "final model:\n";
  for (const auto& m : r["final_model"]) {
    out << "  " << m["effect"].get<std::string>();
    if (m.contains("parameters"))
      out << " " << m["parameters"].dump();
    else
      out << " = " << m["value"].dump() << " +- " << m["sigma"].dump() << " "
          << m["unit"].get<std::string>();
    out << "\n";
  }
  std::snprintf(line, sizeof line, "unexplained %.4f um, noise floor %.4f um: %s (%s)\n",
                r["unexplained_rms_um"].get<double>(), r["noise_floor_um"].get<double>(),
                r["verdict"].get<std::string>().c_str(),
                r["stop_reason"].get<std::string>().c_str());
  out << line;
}

// `--plot DIR`: per step, the measured vs model trace of the test with the largest gap before
// the step, before and after (polar, like the DBB plot).
void WritePlots(const nlohmann::json& r, const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InvalidInput(dir, 0, "--plot", "cannot create the directory");
  int i = 0;
  for (const auto& s : r["steps"]) {
    ++i;
    if (!s.contains("worst_test")) continue;
    const auto& w = s["worst_test"];
    std::vector<render::PolarPlotTrace> traces(3);
    const char* keys[] = {"measured_um", "model_before_um", "model_after_um"};
    const char* labels[] = {"measured", "model before", "model after"};
    const std::array<unsigned char, 3> colours[] = {{200, 60, 20}, {150, 150, 150}, {30, 30, 220}};
    for (int k = 0; k < 3; ++k) {
      traces[k].label = labels[k];
      traces[k].bgr = colours[k];
      for (std::size_t n = 0; n < w["angle_deg"].size(); ++n) {
        traces[k].angle_rad.push_back(w["angle_deg"][n].get<double>() * 3.14159265358979323846 /
                                      180.0);
        traces[k].dev_um.push_back(w[keys[k]][n].get<double>());
      }
    }
    render::PolarPlotOptions opt;
    opt.title = "step " + std::to_string(i) + ": " + s["added_effect"].get<std::string>() +
                " - test " + w["test_id"].get<std::string>() + " " +
                w["direction"].get<std::string>();
    const auto png = render::RenderPolarPlot(traces, std::nullopt, opt);
    const auto path = std::filesystem::path(dir) / ("step" + std::to_string(i) + "_" +
                                                    s["added_effect"].get<std::string>() + ".png");
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    if (!f) throw Error("cannot write " + path.string());
  }
}

int RunDiscover(const Args& args, std::ostream& out) {
  usecases::DiscoveryStudy study;
  if (const auto machine = args.Get("--machine")) {
    study.machine = ingest::ParseMachineJson(ReadFileBytes(*machine), *machine);
  }
  if (args.positional.empty()) throw InvalidInput("", 0, "FILE", "no DBB file given");
  const double samples = args.GetNumber("--samples", 0);
  if (!(samples >= 0 && samples <= 100000) || samples != static_cast<int>(samples))
    throw InvalidInput("", 0, "--samples", "must be a whole number of samples per test (0: all)");
  study.max_samples_per_test = static_cast<int>(samples);
  for (const auto& path : args.positional) {
    study.tests.push_back(ingest::ReadDbb(ReadFileBytes(path), path));
    study.names.push_back(path);
  }
  const auto outcome = usecases::RunDiscoveryStudy(study);
  if (const auto w = args.Get("--write-machine")) {
    if (!outcome.updated_machine)
      throw InvalidInput("", 0, "--write-machine", "only a hexapod discovery produces a machine");
    std::ofstream f(*w, std::ios::binary);
    f << ingest::WriteMachineJson(*outcome.updated_machine);
    if (!f) throw Error("cannot write " + *w);
  }
  if (const auto dir = args.Get("--plot")) WritePlots(outcome.report, *dir);
  if (args.json) {
    out << outcome.report.dump(2) << "\n";
    return 0;
  }
  PrintText(outcome.report, out);
  return 0;
}

KM_CLI_COMMAND("discover",
               "[--machine M.json] FILE... [--samples N] [--write-machine OUT.json] [--plot DIR] "
               "[--json]",
               {"--machine", "--samples", "--write-machine", "--plot"}, RunDiscover);

}  // namespace
}  // namespace km::cli
