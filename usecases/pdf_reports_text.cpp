#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "usecases/pdf_reports_text.h"

namespace km::usecases::report_text {

using nlohmann::json;

std::string Fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "—";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

std::string Fixed(const json& v, int decimals) {
  return v.is_number() ? Fixed(v.get<double>(), decimals) : "—";
}

KeyLabel LabelOf(const std::string& key) {
  static const std::vector<std::pair<std::string, std::string>> kUnits = {
      {"_um_per_m", "µm/m"}, {"_um", "µm"},   {"_mm_min", "mm/min"}, {"_mm", "mm"},
      {"_deg", "°"},         {"_pct", "%"},   {"_ms", "ms"},         {"_s", "s"},
      {"_nm", "nm"},         {"_Nm", "N·m"},  {"_N", "N"},           {"_c", "°C"},
      {"_pa", "Pa"},         {"_ppm", "ppm"}, {"_per_k", "1/K"}};
  KeyLabel out{key, ""};
  for (const auto& [suffix, unit] : kUnits) {
    if (key.size() > suffix.size() && key.ends_with(suffix)) {
      out = {key.substr(0, key.size() - suffix.size()), unit};
      break;
    }
  }
  for (auto& c : out.label) {
    if (c == '_') c = ' ';
  }
  return out;
}

std::string Short(const json& v) {
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  if (v.is_number()) return Fixed(v, 3);
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_null()) return "—";
  if (v.is_array()) {
    std::string out = "(";
    for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + Short(v[i]);
    return out + ")";
  }
  return v.dump();
}

std::string When(const std::string& iso) {
  return iso.empty() ? "—" : iso;
}

namespace {

bool SmallNumberArray(const json& v) {
  if (!v.is_array() || v.empty() || v.size() > 3) return false;
  for (const auto& x : v) {
    if (!x.is_number()) return false;
  }
  return true;
}

// A figure as text: 3 decimals in a unit of length or angle (µm, mm, °, …), else 9 significant
// digits (a refractive index, a ratio, a condition number keep what they carry).
std::string Figure(const json& v, const std::string& unit) {
  if (!v.is_number_float() || !unit.empty()) return Short(v);
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.9g", v.get<double>());
  return buf;
}

void AddFigures(render::ReportTable& t, const json& object, const std::string& prefix,
                const std::vector<std::string>& skip, int depth) {
  for (const auto& [key, v] : object.items()) {
    bool skipped = false;
    for (const auto& s : skip) skipped = skipped || s == key;
    if (skipped) continue;
    const KeyLabel l = LabelOf(key);
    if ((v.is_number() && !v.is_boolean()) || SmallNumberArray(v)) {
      t.rows.push_back({prefix + l.label, v.is_array() ? Short(v) : Figure(v, l.unit), l.unit});
    } else if (v.is_object() && depth < 1) {
      AddFigures(t, v, prefix + l.label + ": ", skip, depth + 1);
    }
  }
}

}  // namespace

render::ReportTable FiguresTable(const json& object, const std::vector<std::string>& skip) {
  render::ReportTable t;
  t.header = {"Figure", "Value", "Unit"};
  t.numeric = {false, true, false};
  if (object.is_object()) AddFigures(t, object, "", skip, 0);
  return t;
}

std::vector<render::ReportBlock> ColumnTables(const json& object) {
  std::vector<render::ReportBlock> out;
  if (!object.is_object()) return out;
  for (const auto& [key, v] : object.items()) {
    if (!v.is_object() || v.empty()) continue;
    std::size_t n = 0;
    bool columns = true;
    for (const auto& [k, col] : v.items()) {
      if (!col.is_array() || (n && col.size() != n)) columns = false;
      if (col.is_array()) n = col.size();
    }
    if (!columns || n == 0) continue;
    // The position (target_mm, position_mm, …) first, then the other columns by name.
    std::vector<std::string> keys;
    for (const auto& [k, col] : v.items()) keys.push_back(k);
    std::stable_partition(keys.begin(), keys.end(),
                          [](const std::string& k) { return k.ends_with("_mm"); });
    render::ReportTable t;
    for (const auto& k : keys) {
      const KeyLabel l = LabelOf(k);
      t.header.push_back(l.unit.empty() ? l.label : l.label + " (" + l.unit + ")");
      t.numeric.push_back(true);
    }
    for (std::size_t i = 0; i < n; ++i) {
      std::vector<std::string> row;
      for (const auto& k : keys) row.push_back(Short(v[k][i]));
      t.rows.push_back(std::move(row));
    }
    out.push_back(render::HeadingBlock(LabelOf(key).label));
    out.push_back(render::TableBlock(std::move(t)));
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> Identification(const ReportSource& s) {
  std::vector<std::pair<std::string, std::string>> id;
  id.push_back({"Machine", s.machine_id});
  std::string test = s.test_id.empty() ? "—" : s.test_id;
  if (!s.direction.empty()) test += " " + s.direction;
  id.push_back({"Test", test});
  id.push_back({"Measured", When(s.measured_at)});
  std::string stored = s.filename;
  if (s.measurement_id > 0) {
    stored = "measurement #" + std::to_string(s.measurement_id) + ", file " + s.filename +
             ", uploaded " + When(s.uploaded_at);
  }
  id.push_back({"Source", stored});
  const auto meta = [&](const char* key) {
    return s.metadata.contains(key) && s.metadata[key].is_string()
               ? s.metadata[key].get<std::string>()
               : std::string("— (not in the file)");
  };
  id.push_back({"Operator", meta("operator")});
  id.push_back({"Instrument", meta("instrument")});
  return id;
}

std::string Footer(const std::string& what, const std::string& printed_at) {
  return "kinemetric · " + what + " · printed " + printed_at;
}

}  // namespace km::usecases::report_text
