// `kinemetric positioning analyze FILE…` and `positioning export FILE --format F`
// (docs/formats.md §3.14, §3.15). Parsing in ingest/positioning_parser, numerics in
// analysis/positioning, JSON and controller tables in usecases/positioning_report and
// usecases/positioning_export.
#include <cstdio>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "usecases/positioning_export.h"
#include "usecases/positioning_report.h"

namespace km::cli {
namespace {

using usecases::PositioningReport;

PositioningReport Analyze(const std::string& path) {
  return usecases::AnalyzePositioning(ingest::ParsePositioningFile(ReadFileBytes(path), path));
}

std::string Cell(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%12.3f", v);
  return buf;
}

// One row of the side-by-side table: a label and one column per file.
void Row(std::ostream& out, const char* label, const std::vector<PositioningReport>& reports,
         double (*value)(const PositioningReport&)) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "  %-34s", label);
  out << buf;
  for (const auto& r : reports) out << Cell(value(r));
  out << "\n";
}

void PrintTable(std::ostream& out, const std::vector<PositioningReport>& reports) {
  out << "positioning (ISO 230-2), um";
  for (std::size_t i = 0; i < reports.size(); ++i) out << (i ? ", " : ": ") << reports[i].file;
  out << "\n";
  using R = const PositioningReport&;
  Row(out, "A  accuracy", reports, [](R r) { return r.figures.iso.accuracy_um; });
  Row(out, "   accuracy up", reports, [](R r) { return r.figures.iso.accuracy_up_um; });
  Row(out, "   accuracy down", reports, [](R r) { return r.figures.iso.accuracy_down_um; });
  Row(out, "B  reversal value", reports, [](R r) { return r.figures.iso.reversal_value_um; });
  Row(out, "   mean reversal value", reports,
      [](R r) { return r.figures.iso.mean_reversal_value_um; });
  Row(out, "E  systematic deviation", reports,
      [](R r) { return r.figures.iso.systematic_deviation_um; });
  Row(out, "   systematic deviation up", reports,
      [](R r) { return r.figures.iso.systematic_deviation_up_um; });
  Row(out, "   systematic deviation down", reports,
      [](R r) { return r.figures.iso.systematic_deviation_down_um; });
  Row(out, "M  mean deviation range", reports,
      [](R r) { return r.figures.iso.mean_deviation_range_um; });
  Row(out, "R  repeatability", reports, [](R r) { return r.figures.iso.repeatability_um; });
  Row(out, "   repeatability up", reports, [](R r) { return r.figures.iso.repeatability_up_um; });
  Row(out, "   repeatability down", reports,
      [](R r) { return r.figures.iso.repeatability_down_um; });
  Row(out, "P  VDI 3441 position uncertainty", reports,
      [](R r) { return r.figures.vdi.position_uncertainty_um; });
  Row(out, "runs", reports, [](R r) { return double(r.figures.runs); });
  Row(out, "targets", reports, [](R r) { return double(r.figures.targets.size()); });
  Row(out, "n (refractive index) - 1, 1e-6", reports,
      [](R r) { return (r.corrections.refractive_index - 1.0) * 1e6; });
  for (const auto& r : reports) {
    for (const auto& w : r.figures.warnings) out << "  warning (" << r.file << "): " << w << "\n";
  }
}

int RunAnalyze(const Args& args, std::ostream& out) {
  if (args.positional.empty()) throw InvalidInput("", 0, "FILE", "give one or more files");
  std::vector<PositioningReport> reports;
  for (const auto& path : args.positional) reports.push_back(Analyze(path));
  if (args.json) {
    out << usecases::PositioningFilesToJson(reports).dump(2) << "\n";
    return 0;
  }
  PrintTable(out, reports);
  return 0;
}

int RunExport(const Args& args, std::ostream& out) {
  if (args.positional.size() != 1) throw InvalidInput("", 0, "FILE", "give exactly one file");
  const auto format = args.Get("--format");
  if (!format) throw InvalidInput("", 0, "--format", "give --format linuxcnc, sinumerik or csv");
  out << usecases::ExportCompensation(Analyze(args.positional.front()), *format);
  return 0;
}

}  // namespace

KM_CLI_COMMAND("positioning analyze", "FILE... [--json]", {}, RunAnalyze);
KM_CLI_COMMAND("positioning export", "FILE --format linuxcnc|sinumerik|csv", {"--format"},
               RunExport);

}  // namespace km::cli
