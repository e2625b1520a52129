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
  std::string out = buf;
  // No "-0.00": a value that rounds to zero is zero.
  if (out.starts_with('-') && out.find_first_not_of("0.", 1) == std::string::npos) out.erase(0, 1);
  return out;
}

std::string Fixed(const json& v, int decimals) {
  return v.is_number() ? Fixed(v.get<double>(), decimals) : "—";
}

KeyLabel LabelOf(const std::string& key) {
  static const std::vector<std::pair<std::string, std::string>> kUnits = {
      {"_urad", "µrad"},     {"_ppm_per_k", "ppm/K"},
      {"_um_per_m", "µm/m"}, {"_um", "µm"},
      {"_mm_min", "mm/min"}, {"_mm", "mm"},
      {"_deg", "°"},         {"_pct", "%"},
      {"_ms", "ms"},         {"_s", "s"},
      {"_nm", "nm"},         {"_Nm", "N·m"},
      {"_N", "N"},           {"_c", "°C"},
      {"_pa", "Pa"},         {"_ppm", "ppm"},
      {"_per_k", "1/K"}};
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
  // The figures the reports know by name first, in the reports' order.
  std::vector<std::string> keys;
  for (const auto& [key, v] : object.items()) keys.push_back(key);
  std::stable_sort(keys.begin(), keys.end(), [](const std::string& a, const std::string& b) {
    return FigureRank(a) < FigureRank(b);
  });
  for (const auto& key : keys) {
    const json& v = object[key];
    bool skipped = false;
    for (const auto& s : skip) skipped = skipped || s == key;
    if (skipped) continue;
    const KeyLabel l = LabelOf(key);
    if ((v.is_number() && !v.is_boolean()) || SmallNumberArray(v)) {
      // A figure the reports know by name is printed so; another by its key in words.
      const std::string name = FigureRank(key) < FigureRank("") ? FigureName(key) : l.label;
      t.rows.push_back({prefix + (prefix.empty() ? Capitalised(name) : name),
                        v.is_array() ? Short(v) : Figure(v, l.unit), l.unit});
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

std::vector<std::size_t> RowsShown(std::size_t n, std::size_t cap,
                                   const std::vector<std::size_t>& keep) {
  std::vector<std::size_t> out;
  if (n <= cap) {
    for (std::size_t i = 0; i < n; ++i) out.push_back(i);
    return out;
  }
  cap = std::max<std::size_t>(cap, 2);
  std::vector<std::size_t> must{0, n - 1};
  for (std::size_t i : keep) {
    if (i < n) must.push_back(i);
  }
  std::sort(must.begin(), must.end());
  must.erase(std::unique(must.begin(), must.end()), must.end());
  if (must.size() > cap) {  // evenly among them
    for (std::size_t j = 0; j < cap; ++j) out.push_back(must[j * (must.size() - 1) / (cap - 1)]);
  } else {
    out = must;
    const std::size_t m = cap - must.size();
    for (std::size_t j = 1; j <= m; ++j) out.push_back(j * (n - 1) / (m + 1));
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Summary Evenly(std::string noun, std::string where, std::size_t cap) {
  return {std::move(noun), std::move(where), {}, "", cap};
}

Shown Summarise(std::size_t n, const Summary& s) {
  Shown out;
  out.rows = RowsShown(n, s.cap, s.keep);
  if (out.rows.size() == n) return out;
  std::vector<std::size_t> keep;
  for (std::size_t i : s.keep) {
    if (i < n) keep.push_back(i);
  }
  std::sort(keep.begin(), keep.end());
  keep.erase(std::unique(keep.begin(), keep.end()), keep.end());
  std::string how = "evenly spaced from the first to the last";
  if (keep.size() + 2 <= s.cap && !keep.empty()) {
    how += ", and every one of the " + s.kept;
  } else if (!keep.empty()) {
    how = "evenly spaced among the " + std::to_string(keep.size()) + " " + s.kept;
  }
  out.sentence = std::to_string(out.rows.size()) + " of " + std::to_string(n) + " " + s.noun +
                 " shown (" + how + "); the full table is in " + s.where + ".";
  return out;
}

std::vector<render::ReportBlock> BoundedTable(render::ReportTable t, const Summary& s) {
  const Shown shown = Summarise(t.rows.size(), s);
  std::vector<render::ReportBlock> out;
  if (!shown.sentence.empty()) {
    std::vector<std::vector<std::string>> rows;
    rows.reserve(shown.rows.size());
    for (std::size_t i : shown.rows) rows.push_back(std::move(t.rows[i]));
    t.rows = std::move(rows);
  }
  out.push_back(render::TableBlock(std::move(t)));
  if (!shown.sentence.empty()) out.push_back(render::ParagraphBlock(shown.sentence));
  return out;
}

std::string ResultAt(const ReportSource& s) {
  if (s.measurement_id) {
    return "the JSON result of the measurement (GET /api/v1/measurements/" +
           std::to_string(*s.measurement_id) + "/results)";
  }
  return "the JSON result of the file " + s.filename + " (docs/formats.md §3)";
}

namespace {

// The rows holding the largest and the smallest number of each column.
std::vector<std::size_t> ExtremeRows(const json& columns, std::size_t n) {
  std::vector<std::size_t> out;
  for (const auto& [k, col] : columns.items()) {
    std::size_t lo = n, hi = n;
    for (std::size_t i = 0; i < n; ++i) {
      if (!col[i].is_number()) continue;
      const double v = col[i].get<double>();
      if (lo == n || v < col[lo].get<double>()) lo = i;
      if (hi == n || v > col[hi].get<double>()) hi = i;
    }
    if (lo < n) out.insert(out.end(), {lo, hi});
  }
  return out;
}

// The number of rows of an object whose members are arrays of one length (0: not such).
std::size_t ColumnRows(const json& v) {
  if (!v.is_object() || v.empty()) return 0;
  std::size_t n = 0;
  for (const auto& [k, col] : v.items()) {
    if (!col.is_array() || (n && col.size() != n)) return 0;
    n = col.size();
  }
  return n;
}

}  // namespace

std::vector<render::ReportBlock> ColumnTable(
    const json& v, const std::vector<std::pair<std::string, std::string>>& columns,
    const std::string& noun, const std::string& where) {
  const std::size_t n = ColumnRows(v);
  if (n == 0) return {};
  render::ReportTable t;
  std::vector<std::string> keys;
  for (const auto& [k, header] : columns) {
    if (!v.contains(k)) continue;
    keys.push_back(k);
    t.header.push_back(header);
    t.numeric.push_back(true);
  }
  // Only the rows shown are written out (a table may hold 100 000 rows).
  const Shown shown = Summarise(n, {noun, where, ExtremeRows(v, n),
                                    noun + " with the largest or smallest value of a column"});
  for (std::size_t i : shown.rows) {
    std::vector<std::string> row;
    for (const auto& k : keys) row.push_back(Short(v[k][i]));
    t.rows.push_back(std::move(row));
  }
  std::vector<render::ReportBlock> out;
  out.push_back(render::HeadingBlock(Capitalised(noun)));
  out.push_back(render::TableBlock(std::move(t)));
  if (!shown.sentence.empty()) out.push_back(render::ParagraphBlock(shown.sentence));
  return out;
}

std::vector<render::ReportBlock> ColumnTables(const json& object, const std::string& where) {
  std::vector<render::ReportBlock> out;
  if (!object.is_object()) return out;
  for (const auto& [key, v] : object.items()) {
    if (ColumnRows(v) == 0) continue;
    // The position (target_mm, position_mm, …) first, then the other columns by name.
    std::vector<std::string> keys;
    for (const auto& [k, col] : v.items()) keys.push_back(k);
    std::stable_partition(keys.begin(), keys.end(),
                          [](const std::string& k) { return k.ends_with("_mm"); });
    std::vector<std::pair<std::string, std::string>> columns;
    for (const auto& k : keys) {
      const KeyLabel l = LabelOf(k);
      columns.push_back({k, l.unit.empty() ? l.label : l.label + " (" + l.unit + ")"});
    }
    for (auto& b : ColumnTable(v, columns, LabelOf(key).label, where)) out.push_back(std::move(b));
  }
  return out;
}

namespace {

// The conditions of the measurement as its file states them: "temperature 20.4 °C" (a DBB or
// form file), "air 21.3 °C, 100850 Pa, 44 % RH; material 22.1 °C" (a laser file).
std::string Environment(const json& m) {
  const auto value = [&](const char* key, const char* unit) {
    return m.contains(key) && m[key].is_string() ? m[key].get<std::string>() + " " + unit
                                                 : std::string();
  };
  std::vector<std::string> parts;
  const auto add = [&](const std::string& what, std::vector<std::string> v) {
    std::string joined;
    for (const auto& x : v) {
      if (!x.empty()) joined += (joined.empty() ? "" : ", ") + x;
    }
    if (!joined.empty()) parts.push_back(what + joined);
  };
  add("temperature ", {value("temperature_c", "°C")});
  add("air ", {value("air_temperature_c", "°C"), value("air_pressure_pa", "Pa"),
               value("air_humidity_pct", "% RH")});
  add("material ", {value("material_temperature_c", "°C")});
  std::string out;
  for (const auto& p : parts) out += (out.empty() ? "" : "; ") + p;
  return out.empty() ? "— (not in the file)" : out;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> Identification(const ReportSource& s) {
  std::vector<std::pair<std::string, std::string>> id;
  id.push_back({"Machine", s.machine_id});
  std::string test = s.test_id.empty() ? "—" : s.test_id;
  if (!s.direction.empty()) test += " " + s.direction;
  id.push_back({"Test", test});
  id.push_back({"Measured", When(s.measured_at)});
  std::string stored = s.filename;
  if (s.measurement_id) {
    stored = "measurement #" + std::to_string(*s.measurement_id) + ", file " + s.filename +
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
  id.push_back({"Environment", Environment(s.metadata)});
  return id;
}

std::string Footer(const std::string& what, const std::string& printed_at) {
  return "kinemetric · " + what + " · printed " + printed_at;
}

namespace {

std::string InputsText(const json& inputs, bool stated) {
  std::string out;
  for (const auto& in : inputs) {
    if (!in.is_object() || in.value("stated", false) != stated) continue;
    out += (out.empty() ? "" : ", ") + InputName(in.value("input", std::string()));
    if (stated) out += " " + Short(in.value("u", json())) + " " + in.value("unit", std::string());
  }
  return out.empty() ? "none" : out;
}

// A short name of an input for a column heading ("u_air_temperature_c" → "air T").
std::string InputLabel(const std::string& input) {
  static const std::pair<const char*, const char*> kLabels[] = {
      {"u_laser_ppm", "laser"},
      {"u_air_temperature_c", "air T"},
      {"u_air_pressure_pa", "air p"},
      {"u_air_humidity_pct", "air RH"},
      {"u_material_temperature_c", "part T"},
      {"u_expansion_ppm_per_k", "expansion"},
      {"u_reading_um", "reading"},
      {"u_bar_length_um", "bar length"},
      {"u_bar_temperature_c", "bar T"},
      {"u_ranging_um", "ranging"}};
  for (const auto& [k, v] : kLabels) {
    if (input == k) return v;
  }
  return InputName(input);
}

// Figure | U | interval low, high | one column a stated input (its contribution), at most six.
render::ReportTable UncertaintyTable(const json& figures, const json& inputs) {
  std::vector<std::string> stated;
  for (const auto& in : inputs) {
    if (in.is_object() && in.value("stated", false) && stated.size() < 6) {
      stated.push_back(in.value("input", std::string()));
    }
  }
  render::ReportTable t;
  t.header = {"Figure", "U (k = 2)", "95 % from", "to"};
  for (const auto& s : stated) t.header.push_back(InputLabel(s));
  t.numeric.assign(t.header.size(), true);
  t.numeric[0] = false;
  // The figures in the order the reports name them (ISO 230-2's for a laser test).
  std::vector<std::string> keys;
  for (const auto& [key, f] : figures.items()) {
    if (f.is_object()) keys.push_back(key);
  }
  std::stable_sort(keys.begin(), keys.end(), [](const std::string& a, const std::string& b) {
    return FigureRank(a) < FigureRank(b);
  });
  for (const auto& key : keys) {
    const json& f = figures[key];
    const json iv = f.value("interval_um", json::array());
    std::vector<std::string> row{Capitalised(FigureName(key)), Fixed(f.value("U_um", json()), 3),
                                 iv.size() == 2 ? Fixed(iv[0], 3) : "—",
                                 iv.size() == 2 ? Fixed(iv[1], 3) : "—"};
    for (const auto& s : stated) {
      json c;
      for (const auto& b : f.value("budget", json::array())) {
        if (b.is_object() && b.value("input", std::string()) == s)
          c = b.value("contribution_um", json());
      }
      row.push_back(Fixed(c, 3));
    }
    t.rows.push_back(std::move(row));
  }
  return t;
}

}  // namespace

std::vector<render::ReportBlock> UncertaintyBlocks(const json& u, const std::string& of) {
  std::vector<render::ReportBlock> out;
  if (!u.is_object()) return out;
  out.push_back(render::HeadingBlock("Uncertainty" + of));
  const json inputs = u.value("inputs", json::array());
  const json figures = u.value("figures", json::object());
  if (!figures.is_object() || figures.empty()) {
    out.push_back(render::ParagraphBlock("The file states no input uncertainty (" +
                                         InputsText(inputs, false) +
                                         "): the figures carry no expanded uncertainty."));
    return out;
  }
  out.push_back(render::ParagraphBlock(
      "Method: " + u.value("method", std::string()) + ", " + Short(u.value("draws", json())) +
      " draws, seed " + Short(u.value("seed", json())) +
      "; U = k·u with k = 2, u the standard deviation of the draws; the 95 % interval is the "
      "probabilistically symmetric coverage interval. Inputs stated (standard uncertainties): " +
      InputsText(inputs, true) + ". Not stated (taken as 0): " + InputsText(inputs, false) +
      ". In µm: U (k = 2), the 95 % interval, and the budget: each figure's standard uncertainty "
      "with one input alone (laser: reading scale; air T, p, RH: through the refractive index; "
      "part T and expansion: through the correction to 20 °C; reading, bar length, bar T: the "
      "ball bar's)."));
  out.push_back(render::TableBlock(UncertaintyTable(figures, inputs)));
  for (const auto& w : u.value("warnings", json::array())) {
    if (w.is_string())
      out.push_back(render::ParagraphBlock("Note: " + Readable(w.get<std::string>())));
  }
  return out;
}

}  // namespace km::usecases::report_text
