// kinemetric dbb analyze FILE… [--json]
#include <cstdio>
#include <ostream>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "ingest/dbb_parser.h"
#include "server/report.h"

namespace km::cli {
namespace {

int RunDbbAnalyze(const Args& args, std::ostream& out) {
  if (args.positional.empty()) throw InvalidInput("", 0, "FILE", "no DBB file given");
  std::vector<dbb::DbbTest> tests;
  for (const auto& path : args.positional) {
    tests.push_back(ingest::ParseDbb(ReadFileBytes(path), path));
  }
  nlohmann::json report;
  for (std::size_t i = 0; i < tests.size(); ++i) {
    try {
      // Analyse one by one so that an analysis error names its file.
      (void)dbb::AnalyzeCircularTest(tests[i]);
    } catch (const InvalidInput& e) {
      throw InvalidInput(args.positional[i], e.line(), e.field(), e.reason());
    }
  }
  report = server::DbbReportJson(tests);
  if (args.json) {
    out << report.dump(2) << "\n";
    return 0;
  }
  char line[256];
  std::snprintf(line, sizeof line, "%-20s %-4s %-17s %10s %10s %12s %12s\n", "test_id", "dir",
                "mode", "X0 um", "Y0 um", "avg rad um", "circ. um");
  out << line;
  for (const auto& t : report["tests"]) {
    std::snprintf(line, sizeof line, "%-20s %-4s %-17s %10.3f %10.3f %12.3f %12.3f\n",
                  t["test_id"].get<std::string>().c_str(),
                  t["direction"].get<std::string>().c_str(), t["mode"].get<std::string>().c_str(),
                  t["centre_offset_um"][0].get<double>(), t["centre_offset_um"][1].get<double>(),
                  t["average_radial_error_um"].get<double>(), t["circularity_um"].get<double>());
    out << line;
  }
  return 0;
}

KM_CLI_COMMAND("dbb analyze", "FILE... [--json]", {}, RunDbbAnalyze);

}  // namespace
}  // namespace km::cli
