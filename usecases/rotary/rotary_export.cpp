#include "usecases/rotary/rotary_export.h"

#include <cstdio>

#include "analysis/core/errors.h"

namespace km::usecases {
namespace {

std::string Mm(const std::optional<double>& v) {
  if (!v) return "not determined";
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.4f", *v);
  return buf;
}

std::string Row(const char* format, const std::string& a, const std::string& b,
                const std::string& c, const std::string& d) {
  char buf[256];
  std::snprintf(buf, sizeof buf, format, a.c_str(), b.c_str(), c.c_str(), d.c_str());
  return buf;
}

std::string MechanicalLine(const RotaryReport& r, std::size_t i, const char* format) {
  const auto& e = r.result.errors[i];
  const std::string name(rotary::LocationErrorNames(r.result.kinematics)[i]);
  char value[64];
  if (e.identifiable) {
    std::snprintf(value, sizeof value, "%.2f urad +- %.2f", e.value, e.sigma);
  } else {
    std::snprintf(value, sizeof value, "not determined");
  }
  return Row(format, name, value, "adjust mechanically", "");
}

std::string LinuxCnc(const RotaryReport& r, const rotary::PivotCorrection& p) {
  std::string out = "# " + p.module + " pivot parameters corrected by kinemetric rotary export\n";
  out += "# from " + r.file.file + " (" + r.file.machine_id + ", " + r.file.test_id + "), mm\n";
  for (const auto& q : p.params) {
    if (q.corrected_mm) out += "setp " + p.module + "." + q.name + " " + Mm(q.corrected_mm) + "\n";
  }
  out += "#\n" + Row("# %-12s %14s %14s %14s\n", "parameter", "nominal mm", "correction mm",
                     "corrected mm");
  for (const auto& q : p.params) {
    out += Row("# %-12s %14s %14s %14s\n", q.name, Mm(q.nominal_mm), Mm(q.delta_mm),
               Mm(q.corrected_mm));
  }
  out += "# not correctable by pivot parameters (the axis directions):\n";
  for (std::size_t i : p.mechanical) out += MechanicalLine(r, i, "# %-4s %-24s %s%s\n");
  return out;
}

std::string Csv(const RotaryReport& r, const rotary::PivotCorrection& p) {
  std::string out = "parameter,nominal_mm,delta_mm,corrected_mm\n";
  for (const auto& q : p.params) {
    out += p.module + "." + q.name + "," + Mm(q.nominal_mm) + "," + Mm(q.delta_mm) + "," +
           Mm(q.corrected_mm) + "\n";
  }
  out += "error,value,action\n";
  for (std::size_t i : p.mechanical) out += MechanicalLine(r, i, "%s,%s,%s%s\n");
  return out;
}

}  // namespace

rotary::PivotCorrection RotaryPivots(const RotaryReport& r) {
  rotary::LocationErrors values{};
  std::array<bool, rotary::kLocationErrorCount> determined{};
  for (std::size_t i = 0; i < rotary::kLocationErrorCount; ++i) {
    determined[i] = r.result.errors[i].identifiable;
    values[i] = determined[i] ? r.result.errors[i].value : 0.0;
  }
  return rotary::LinuxCncPivots(r.file.test.setup, values, determined);
}

std::string ExportRotary(const RotaryReport& r, const std::string& format) {
  const rotary::PivotCorrection p = RotaryPivots(r);
  if (format == "linuxcnc") return LinuxCnc(r, p);
  if (format == "csv") return Csv(r, p);
  throw InvalidInput("", 0, "--format",
                     "'" + format + "' is not an export format (linuxcnc or csv)");
}

}  // namespace km::usecases
