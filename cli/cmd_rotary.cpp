// `kinemetric rotary analyze FILE [--json]` (docs/formats.md §3.18): the eight location errors
// of a trunnion table's rotary axes from an R-test file (§1.10); `kinemetric rotary discover
// FILE [--json]`: the position-dependent errors beside them, named one step at a time
// (docs/methods.md §17.6); `kinemetric rotary export FILE --format linuxcnc|csv`: the pivot
// parameters of LinuxCNC's trunnion kinematics corrected (§17.7). Parsing in
// ingest/rotary/rotary_parser, numerics in analysis/rotary, JSON in usecases/rotary/.
#include <cstdio>
#include <ostream>
#include <string>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "usecases/rotary/rotary_discover_report.h"
#include "usecases/rotary/rotary_export.h"
#include "usecases/rotary/rotary_report.h"

namespace km::cli {
namespace {

using usecases::RotaryReport;

std::string RotaryLine(const char* format, double a, double b) {
  char buf[96];
  std::snprintf(buf, sizeof buf, format, a, b);
  return buf;
}

void PrintRotaryErrors(std::ostream& out, const RotaryReport& r) {
  const auto k = r.result.kinematics;
  const auto& names = rotary::LocationErrorNames(k);
  for (std::size_t i = 0; i < rotary::kLocationErrorCount; ++i) {
    const auto& e = r.result.errors[i];
    const char* unit = rotary::IsAngularError(i) ? "urad" : "um";
    out << "  " << names[i] << " ";
    if (e.identifiable) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "%10.2f %-4s  sigma %6.2f\n", e.value, unit, e.sigma);
      out << buf;
    } else {
      out << "  not identifiable from these poses\n";
    }
  }
}

void PrintRotary(std::ostream& out, const RotaryReport& r) {
  const auto& res = r.result;
  out << "rotary axes (" << rotary::KinematicsName(res.kinematics) << "), " << r.file.file << ": "
      << res.poses << " poses\n";
  out << "location errors (ISO 230-1):\n";
  PrintRotaryErrors(out, r);
  out << "  rank " << res.rank << " of " << rotary::kLocationErrorCount;
  if (res.condition) out << RotaryLine(", condition %.3g", *res.condition, 0.0);
  out << "\n";
  if (res.not_separable.empty())
    out << "  all eight location errors are determined by these poses\n";
  out << RotaryLine("  RMS before %.3f um, after %.3f um", res.measured_rms_um, res.residual_rms_um)
      << RotaryLine(" (s = %.3f um)\n", res.sigma_um, 0.0);
  for (const auto& w : r.warnings) out << "  warning: " << w << "\n";
}

int RunRotaryAnalyze(const Args& args, std::ostream& out) {
  if (args.positional.size() != 1) throw InvalidInput("", 0, "FILE", "give exactly one file");
  const std::string& path = args.positional.front();
  const RotaryReport r =
      usecases::AnalyzeRotary(ingest::ParseRotaryFile(ReadFileBytes(path), path));
  if (args.json) {
    out << usecases::RotaryReportToJson(r).dump(2) << "\n";
    return 0;
  }
  PrintRotary(out, r);
  return 0;
}

void PrintNamedEffects(std::ostream& out, const usecases::RotaryDiscoveryReport& r) {
  const auto& d = r.result;
  for (rotary::RotaryEffect e : d.named) {
    out << "named: " << rotary::EffectName(d.kinematics, e) << "\n";
    const rotary::ParameterRange range = rotary::EffectRange(e);
    for (std::size_t j = range.first; j < range.first + range.count; ++j) {
      out << "  " << rotary::ParameterKey(d.kinematics, j);
      if (d.final_fit.determined[j]) {
        out << RotaryLine(" %.3f +- %.3f\n", d.final_fit.value[j], d.final_fit.sigma[j]);
      } else {
        out << " not determined by these poses\n";
      }
    }
  }
  if (d.named.empty()) out << "nothing named beside the location errors\n";
}

int RunRotaryDiscover(const Args& args, std::ostream& out) {
  if (args.positional.size() != 1) throw InvalidInput("", 0, "FILE", "give exactly one file");
  const std::string& path = args.positional.front();
  const auto r = usecases::DiscoverRotary(ingest::ParseRotaryFile(ReadFileBytes(path), path));
  if (args.json) {
    out << usecases::RotaryDiscoveryToJson(r).dump(2) << "\n";
    return 0;
  }
  out << "missing effects, rotary axes (" << rotary::KinematicsName(r.result.kinematics) << "), "
      << path << "\n";
  for (const auto& s : usecases::RotaryDiscoverySteps(r)) out << "  " << s << "\n";
  PrintNamedEffects(out, r);
  out << "verdict: " << r.result.verdict << "\n";
  if (!r.result.misfit.empty()) out << "  " << r.result.misfit << "\n";
  return 0;
}

int RunRotaryExport(const Args& args, std::ostream& out) {
  if (args.positional.size() != 1) throw InvalidInput("", 0, "FILE", "give exactly one file");
  const std::string& path = args.positional.front();
  const RotaryReport r =
      usecases::AnalyzeRotary(ingest::ParseRotaryFile(ReadFileBytes(path), path));
  out << usecases::ExportRotary(r, args.Get("--format").value_or("linuxcnc"));
  return 0;
}

}  // namespace

KM_CLI_COMMAND("rotary analyze", "FILE [--json]", {}, RunRotaryAnalyze);
KM_CLI_COMMAND("rotary discover", "FILE [--json]", {}, RunRotaryDiscover);
KM_CLI_COMMAND("rotary export", "FILE [--format linuxcnc|csv]", {"--format"}, RunRotaryExport);

}  // namespace km::cli
