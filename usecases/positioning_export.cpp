#include "usecases/positioning_export.h"

#include <cstdio>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/positioning/compensation.h"
#include "ingest/identifiers.h"

namespace km::usecases {
namespace {

std::string PlainFixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  if (s == "-0" || s.find_first_not_of("-0.") == std::string::npos) {
    s.erase(0, s.front() == '-' ? 1 : 0);  // no "-0.000000"
  }
  return s;
}

// Mean bidirectional deviation of each target (µm), ascending targets.
std::vector<double> MeanDeviations(const PositioningReport& r) {
  std::vector<double> m;
  for (const auto& t : r.figures.targets) m.push_back(t.mean_bidirectional_um);
  return m;
}

std::vector<double> Targets(const PositioningReport& r) {
  return r.compensation.target_mm;
}

// A name copied into a controller's program: only when it is of the safe alphabet
// (ingest::IsControllerSafe), so that nothing a client wrote can start a program line.
std::string ControllerName(const std::string& what, const std::string& name) {
  if (ingest::IsControllerSafe(name)) return what + " " + name;
  return what + " (name left out: not of the letters, digits and _ . - : a program may carry)";
}

}  // namespace

std::string ExportLinuxCnc(const PositioningReport& report) {
  const auto& t = report.compensation;
  std::string out;
  for (std::size_t i = 0; i < t.target_mm.size(); ++i) {
    out += PlainFixed(t.target_mm[i], 6) + " " + PlainFixed(t.forward_um[i] / 1000.0, 6) + " " +
           PlainFixed(t.reverse_um[i] / 1000.0, 6) + "\n";
  }
  return out;
}

std::string ExportSinumerik(const PositioningReport& report) {
  const std::vector<double> x = Targets(report);
  const std::vector<double> y = MeanDeviations(report);
  const positioning::EvenGrid grid = positioning::EvenGridOf(x);
  const double max_mm = grid.start_mm + grid.step_mm * double(grid.count - 1);
  std::string out = "%_N_AX_EEC_INI\nCHANDATA(1)\n";
  out += "; kinemetric: leadscrew error compensation of " +
         ControllerName("machine", report.machine_id) + ", " + ControllerName("axis", report.axis) +
         " (rename AX1 to its machine axis)\n";
  out +=
      "; values in mm = mean bidirectional deviation; a positive value moves the axis in the "
      "negative direction\n";
  out += grid.was_even ? "; the targets are evenly spaced: one value per target\n"
                       : "; the targets are not evenly spaced: values linearly interpolated onto "
                         "an even grid of " +
                             std::to_string(grid.count) + " points\n";
  out += "; mean reversal B = " + PlainFixed(report.figures.iso.mean_reversal_value_um, 3) +
         " um is not in this table (backlash compensation)\n";
  out += "$AA_ENC_COMP_STEP[0,AX1]=" + PlainFixed(grid.step_mm, 6) + "\n";
  out += "$AA_ENC_COMP_MIN[0,AX1]=" + PlainFixed(grid.start_mm, 6) + "\n";
  out += "$AA_ENC_COMP_MAX[0,AX1]=" + PlainFixed(max_mm, 6) + "\n";
  out += "$AA_ENC_COMP_IS_MODULO[0,AX1]=0\n";
  for (std::size_t i = 0; i < grid.count; ++i) {
    const double p = i + 1 == grid.count ? x.back() : grid.start_mm + grid.step_mm * double(i);
    const double v = positioning::Interpolate(x, y, p) / 1000.0;
    out += "$AA_ENC_COMP[0," + std::to_string(i) + ",AX1]=" + PlainFixed(v, 6) + "\n";
  }
  out += "M17\n";
  return out;
}

std::string ExportCompensationCsv(const PositioningReport& report) {
  const auto& t = report.compensation;
  std::string out = "target_mm,forward_um,reverse_um,mean_bidirectional_um\n";
  for (std::size_t i = 0; i < t.target_mm.size(); ++i) {
    out += PlainFixed(t.target_mm[i], 6) + "," + PlainFixed(t.forward_um[i], 4) + "," +
           PlainFixed(t.reverse_um[i], 4) + "," +
           PlainFixed(report.figures.targets[i].mean_bidirectional_um, 4) + "\n";
  }
  return out;
}

std::string ExportCompensation(const PositioningReport& report, const std::string& format) {
  if (format == "linuxcnc") return ExportLinuxCnc(report);
  if (format == "sinumerik") return ExportSinumerik(report);
  if (format == "csv") return ExportCompensationCsv(report);
  throw InvalidInput("", 0, "--format",
                     "'" + format + "' is not a compensation format (linuxcnc, sinumerik or csv)");
}

}  // namespace km::usecases
