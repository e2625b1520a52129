// kinemetric discover [--machine M.json] FILE… [--json]
// Serial machines (DBB files, no --machine or a machine of kind "serial"): the discovery ladder
// of analysis/dbb/discovery.h over all files jointly. Hexapods: not available yet (exit 1).
#include <cstdio>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/discovery.h"
#include "cli/command.h"
#include "ingest/dbb_parser.h"
#include "ingest/machine_json.h"

namespace km::cli {
namespace {

nlohmann::json Values(const std::vector<double>& v) {
  if (v.size() == 1) return v[0];
  return nlohmann::json(v);
}

nlohmann::json DiscoveryJson(const dbb::DiscoveryResult& r, dbb::Plane plane) {
  nlohmann::json steps = nlohmann::json::array();
  for (const auto& s : r.steps) {
    const auto& e = s.evidence;
    nlohmann::json params = nlohmann::json::object();
    for (const auto& [k, v] : e.parameters) params[k] = v;
    nlohmann::json ev = {{"rss_before_um2", e.rss_before_um2},
                         {"rss_after_um2", e.rss_after_um2},
                         {"f_statistic", e.f_statistic},
                         {"df_numerator", e.df_numerator},
                         {"df_denominator", e.df_denominator},
                         {"p_value", e.p_value},
                         {"log10_p_value", e.log10_p_value},
                         {"value", Values(e.value)},
                         {"unit", e.unit},
                         {"sigma", Values(e.sigma)},
                         {"z_score", e.z_score},
                         {"parameters", params},
                         {"indistinguishable_from", e.indistinguishable_from}};
    if (!e.runner_up.empty()) {
      ev["runner_up"] = e.runner_up;
      ev["runner_up_rss_drop_um2"] = e.runner_up_rss_drop_um2;
    } else {
      ev["runner_up"] = nullptr;
      ev["runner_up_rss_drop_um2"] = 0.0;
    }
    steps.push_back({{"added_effect", s.added_effect},
                     {"evidence", ev},
                     {"gap_rms_before_um", s.gap_rms_before_um},
                     {"gap_rms_after_um", s.gap_rms_after_um}});
  }
  nlohmann::json model = nlohmann::json::array();
  for (const auto& m : r.final_model) {
    nlohmann::json x = {{"effect", m.effect},
                        {"value", Values(m.value)},
                        {"unit", m.unit},
                        {"sigma", Values(m.sigma)}};
    if (!m.shape.empty()) {
      nlohmann::json sh = nlohmann::json::object();
      for (const auto& [k, v] : m.shape) sh[k] = v;
      x["shape"] = sh;
    }
    model.push_back(x);
  }
  return {{"plane", dbb::ToString(plane)},
          {"steps", steps},
          {"final_model", model},
          {"unexplained_rms_um", r.unexplained_rms_um},
          {"noise_floor_um", r.noise_floor_um},
          {"stop_reason", r.stop_reason},
          {"rejected", r.rejected},
          {"not_identifiable", r.not_identifiable}};
}

int RunDiscover(const Args& args, std::ostream& out) {
  if (const auto machine = args.Get("--machine")) {
    const auto m = ingest::ParseMachineJson(ReadFileBytes(*machine), *machine);
    if (m.kind == "hexapod") {
      throw Error(
          "hexapod discovery (gravity deflection, joint friction of [PM-600 report] ch. 3-4) is "
          "not "
          "available yet; discover works on serial-machine DBB files");
    }
  }
  if (args.positional.empty()) throw InvalidInput("", 0, "FILE", "no DBB file given");
  std::vector<dbb::DbbTest> tests;
  std::vector<dbb::DiagnosisTrace> traces;
  for (const auto& path : args.positional) {
    tests.push_back(ingest::ParseDbb(ReadFileBytes(path), path));
    try {
      const dbb::DbbTest& t = tests.back();
      traces.push_back(dbb::MakeDiagnosisTrace(t, dbb::AnalyzeCircularTest(t)));
    } catch (const InvalidInput& e) {
      throw InvalidInput(path, e.line(), e.field(), e.reason());
    }
    if (tests.back().plane != tests.front().plane) {
      throw InvalidInput(path, 0, "plane",
                         std::string("all files must be in one plane (") +
                             dbb::ToString(tests.front().plane) + " in " + args.positional.front() +
                             ")");
    }
  }
  const dbb::Plane plane = tests.front().plane;
  const dbb::DiscoveryResult r = dbb::DiscoverSerialDbb(traces, plane);
  if (args.json) {
    out << DiscoveryJson(r, plane).dump(2) << "\n";
    return 0;
  }
  char line[320];
  std::snprintf(line, sizeof line, "%-4s %-20s %14s %14s %12s %10s\n", "step", "added effect",
                "gap before um", "gap after um", "log10 p", "value");
  out << line;
  for (std::size_t i = 0; i < r.steps.size(); ++i) {
    const auto& s = r.steps[i];
    std::snprintf(line, sizeof line, "%-4zu %-20s %14.4f %14.4f %12.1f %10.4g %s\n", i + 1,
                  s.added_effect.c_str(), s.gap_rms_before_um, s.gap_rms_after_um,
                  s.evidence.log10_p_value, s.evidence.value.front(), s.evidence.unit.c_str());
    out << line;
  }
  out << "final model:\n";
  for (const auto& m : r.final_model) {
    out << "  " << m.effect << " = " << Values(m.value).dump() << " +- " << Values(m.sigma).dump()
        << " " << m.unit << "\n";
  }
  std::snprintf(line, sizeof line, "unexplained %.4f um, noise floor %.4f um (%s)\n",
                r.unexplained_rms_um, r.noise_floor_um, r.stop_reason.c_str());
  out << line;
  return 0;
}

KM_CLI_COMMAND("discover", "[--machine M.json] FILE... [--json]", {"--machine"}, RunDiscover);

}  // namespace
}  // namespace km::cli
