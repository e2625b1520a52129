// `kinemetric tracker selfcal FILE [--json]`: laser-tracker multilateration self-calibration
// ([Tracker paper]) and volumetric error map with its geometric decomposition.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>

#include "analysis/core/errors.h"
#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/volumetric_decomposition.h"
#include "cli/command.h"
#include "ingest/tracker_parser.h"
#include "usecases/tracker_report.h"

namespace km::cli {
using json = nlohmann::json;
using usecases::AnalyzeTrackerFile;
using usecases::TrackerResultToJson;
namespace {

int RunSelfcal(const Args& args, std::ostream& out) {
  if (args.positional.size() != 1) {
    throw InvalidInput("", 0, "FILE", "tracker selfcal takes exactly one measurement file");
  }
  const std::string& path = args.positional[0];
  tracker::SelfCalOptions opt;
  opt.reject_outliers = !args.Has("--no-reject");
  opt.outlier_k = args.GetNumber("--outlier-k", opt.outlier_k);
  tracker::DecompositionOptions dopt;
  const double order = args.GetNumber("--order", dopt.max_order);
  if (order != std::floor(order)) throw InvalidInput("", 0, "--order", "must be an integer");
  dopt.max_order = static_cast<int>(order);
  opt.Check();
  dopt.Check();
  const json j = AnalyzeTrackerFile(ReadFileBytes(path), path, opt, dopt);
  if (args.json) {
    out << j.dump(2) << "\n";
    return 0;
  }
  char buf[256];
  out << "laser-tracker self-calibration: " << path << " (" << j["mode"].get<std::string>() << ", "
      << j["trackers_mm"].size() << " trackers, " << j["points_mm"].size() << " points)\n";
  for (std::size_t t = 0; t < j["trackers_mm"].size(); ++t) {
    const auto& p = j["trackers_mm"][t];
    std::snprintf(buf, sizeof buf, "  tracker %zu: %10.4f %10.4f %10.4f mm\n", t + 1,
                  p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
    out << buf;
  }
  double s = 0, mx = 0;
  int cnt = 0;
  for (const auto& e : j["volumetric_error_um"]) {
    if (e.is_null()) continue;
    const double n = std::hypot(e[0].get<double>(), e[1].get<double>(), e[2].get<double>());
    s += n * n;
    mx = std::max(mx, n);
    ++cnt;
  }
  std::snprintf(buf, sizeof buf,
                "  residual rms %.3f um, condition number %.3g, volumetric error rms %.3f um, "
                "max %.3f um, %zu readings rejected\n",
                j["residual_rms_um"].get<double>(), j["condition_number"].get<double>(),
                cnt ? std::sqrt(s / cnt) : 0.0, mx, j["rejected_readings"].size());
  out << buf;
  for (const auto& w : j["warnings"]) out << "  warning: " << w.get<std::string>() << "\n";
  if (!j["decomposition"].is_null()) {
    const auto& d = j["decomposition"];
    std::snprintf(buf, sizeof buf,
                  "  scale x/y/z %.2f %.2f %.2f ppm; squareness xy/yz/zx %.2f %.2f %.2f um/m\n",
                  d["scale_ppm"]["x"].get<double>(), d["scale_ppm"]["y"].get<double>(),
                  d["scale_ppm"]["z"].get<double>(), d["squareness_um_per_m"]["xy"].get<double>(),
                  d["squareness_um_per_m"]["yz"].get<double>(),
                  d["squareness_um_per_m"]["zx"].get<double>());
    out << buf;
  }
  return 0;
}

}  // namespace

KM_CLI_COMMAND("tracker selfcal",
               "FILE [--json] [--no-reject] [--outlier-k K] [--order K]  laser-tracker "
               "multilateration self-calibration and volumetric error map",
               {"--outlier-k", "--order"}, RunSelfcal);

}  // namespace km::cli
