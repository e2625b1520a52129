// kinemetric dbb analyze FILE… [--json] [--plot OUT.png]
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <ostream>

#include "analysis/core/errors.h"
#include "analysis/dbb/full_analysis.h"
#include "cli/command.h"
#include "ingest/file_formats.h"
#include "render/dbb_plot.h"
#include "usecases/dbb_report.h"

namespace km::cli {
namespace {

void WritePlots(const std::string& out_path, const std::vector<dbb::DbbTest>& tests,
                const dbb::DbbReport& report) {
  namespace fs = std::filesystem;
  const fs::path base(out_path);
  for (std::size_t i = 0; i < tests.size(); ++i) {
    // One test (or one pair, drawn together): OUT.png; several: OUT-<test_id>-<dir>.png.
    fs::path p = base;
    if (tests.size() > 1) {
      p = base.parent_path() / (base.stem().string() + "-" + tests[i].test_id + "-" +
                                dbb::ToString(tests[i].direction) + base.extension().string());
    }
    const auto png = render::DbbPolarPlotPng(report, i);
    std::ofstream f(p, std::ios::binary);
    f.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    if (!f) throw Error("cannot write the plot to " + p.string());
  }
}

int RunDbbAnalyze(const Args& args, std::ostream& out) {
  if (args.positional.empty()) throw InvalidInput("", 0, "FILE", "no DBB file given");
  std::vector<dbb::DbbTest> tests;
  for (const auto& path : args.positional) {
    tests.push_back(ingest::ReadDbb(ReadFileBytes(path), path));
  }
  for (std::size_t i = 0; i < tests.size(); ++i) {
    // Check each file on its own first so that an analysis error names its file.
    (void)InFile(args.positional[i], [&] { return dbb::AnalyzeCircularTest(tests[i]); });
  }
  const dbb::DbbReport analysis = dbb::AnalyzeDbbSet(tests);
  const nlohmann::json report = usecases::DbbReportJson(tests, analysis);
  if (const auto plot = args.Get("--plot")) WritePlots(*plot, tests, analysis);
  if (args.json) {
    out << report.dump(2) << "\n";
    return 0;
  }
  char line[256];
  std::snprintf(line, sizeof line, "%-20s %-4s %-17s %10s %10s %12s %12s %12s\n", "test_id", "dir",
                "mode", "X0 um", "Y0 um", "avg rad um", "circ. um", "min-zone um");
  out << line;
  for (const auto& t : report["tests"]) {
    std::snprintf(line, sizeof line, "%-20s %-4s %-17s %10.3f %10.3f %12.3f %12.3f %12.3f\n",
                  t["test_id"].get<std::string>().c_str(),
                  t["direction"].get<std::string>().c_str(), t["mode"].get<std::string>().c_str(),
                  t["centre_offset_um"][0].get<double>(), t["centre_offset_um"][1].get<double>(),
                  t["average_radial_error_um"].get<double>(), t["circularity_um"].get<double>(),
                  t["min_zone_circularity_um"].get<double>());
    out << line;
    for (const auto& d : t["diagnosis"]) {
      out << "    " << d["effect"].get<std::string>() << " = " << d["value"].dump() << " "
          << d["unit"].get<std::string>() << " (" << d["contribution_pct"].get<double>()
          << " % of circularity)\n";
    }
  }
  for (const auto& p : report["pairs"]) {
    std::snprintf(line, sizeof line,
                  "pair %-15s hysteresis %.3f um, bidirectional circular deviation %.3f um\n",
                  p["test_id"].get<std::string>().c_str(),
                  p["circular_hysteresis_um"].get<double>(),
                  p["bidirectional_circular_deviation_um"].get<double>());
    out << line;
  }
  return 0;
}

KM_CLI_COMMAND("dbb analyze", "FILE... [--json] [--plot OUT.png]", {"--plot"}, RunDbbAnalyze);

}  // namespace
}  // namespace km::cli
