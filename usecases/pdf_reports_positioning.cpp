// The report of a laser positioning test (usecases/pdf_reports_text.h PositioningBlocks), as a
// laser calibration report reads: the chart of the mean deviations x̄↑, x̄↓ with their ±2s bands
// against the target position (as web/static/positioning.js draws it), the ISO 230-2:2014
// figures in the standard's order with their letters, units and expanded uncertainty, the
// VDI/DGQ 3441 figures, the uncertainty of the figures, the conditions of the measurement with
// the corrections applied, and the table of the targets.
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "usecases/pdf_reports_text.h"

namespace km::usecases::report_text {
namespace {

using nlohmann::json;

std::vector<double> Numbers(const json& targets, const char* key) {
  std::vector<double> out;
  if (!targets.contains(key) || !targets[key].is_array()) return out;
  for (const auto& v : targets[key]) {
    out.push_back(v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN());
  }
  return out;
}

// The mean deviation of each direction with its ±2s band over the target position.
render::ReportChart DeviationChart(const json& targets) {
  render::ReportChart c;
  c.title = "Mean deviation x̄ ± 2s at each target, per direction";
  c.x_label = "Target position (mm)";
  c.y_label = "Deviation (µm)";
  const auto x = Numbers(targets, "target_mm");
  const std::pair<const char*, const char*> dirs[] = {{"up", "↑"}, {"down", "↓"}};
  for (const auto& [dir, arrow] : dirs) {
    const auto mean = Numbers(targets, (std::string("mean_") + dir + "_um").c_str());
    const auto s = Numbers(targets, (std::string("s_") + dir + "_um").c_str());
    if (mean.size() != x.size()) continue;
    render::ReportBand band{x, mean, mean, c.series.size()};
    for (std::size_t i = 0; i < x.size() && i < s.size(); ++i) {
      band.lo[i] = mean[i] - 2 * s[i];
      band.hi[i] = mean[i] + 2 * s[i];
    }
    c.bands.push_back(std::move(band));
    c.series.push_back({std::string("x̄") + arrow + " ± 2s (" +
                            (std::string(dir) == "up" ? "towards +" : "towards −") + ")",
                        x, mean});
  }
  return c;
}

std::string Plain(const json& v, const char* format) {
  if (!v.is_number()) return "—";
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v.get<double>());
  return buf;
}

// "± 2.648 µm (k = 2)" for a figure the uncertainty object holds, else "not stated".
std::string ExpandedU(const json& results, const std::string& key) {
  const json u = results.value("uncertainty", json::object());
  const json figures = u.is_object() ? u.value("figures", json::object()) : json::object();
  if (!figures.is_object() || !figures.contains(key) || !figures[key].is_object()) {
    return "not stated";
  }
  const json& f = figures[key];
  if (!f.contains("U_um") || !f["U_um"].is_number()) return "not stated";
  const json k = f.contains("k") ? f["k"] : u.value("k", json(2));
  return "± " + Fixed(f["U_um"], 3) + " µm (k = " + Plain(k, "%g") + ")";
}

struct Letter {
  const char* symbol;
  const char* key;
  const char* name;
};

// ISO 230-2:2014 clause 2, in the standard's order.
constexpr Letter kIso[] = {
    {"A", "accuracy_um", "Accuracy of positioning, bidirectional"},
    {"A↑", "accuracy_up_um", "Unidirectional accuracy of positioning, towards +"},
    {"A↓", "accuracy_down_um", "Unidirectional accuracy of positioning, towards −"},
    {"E", "systematic_deviation_um", "Systematic positioning error, bidirectional"},
    {"E↑", "systematic_deviation_up_um", "Unidirectional systematic positioning error, towards +"},
    {"E↓", "systematic_deviation_down_um",
     "Unidirectional systematic positioning error, towards −"},
    {"M", "mean_deviation_range_um", "Range of the mean bidirectional positioning error"},
    {"B", "reversal_value_um", "Reversal error of the axis"},
    {"B̄", "mean_reversal_value_um", "Mean reversal error of the axis"},
    {"R", "repeatability_um", "Repeatability of positioning, bidirectional"},
    {"R↑", "repeatability_up_um", "Unidirectional repeatability of positioning, towards +"},
    {"R↓", "repeatability_down_um", "Unidirectional repeatability of positioning, towards −"},
};

// VDI/DGQ 3441, under vdi3441 in the result.
constexpr Letter kVdi[] = {
    {"P", "P_um", "Position uncertainty"},
    {"Ps", "Ps_um", "Positional scatter (largest)"},
    {"U", "U_um", "Reversal span (largest)"},
    {"Pa", "Pa_um", "Positional deviation"},
};

render::ReportTable LetterTable(const json& results, const json& object, const Letter* letters,
                                std::size_t n, const std::string& prefix) {
  render::ReportTable t;
  t.header = {"Symbol", "Figure", "Value", "Unit", "U (expanded)"};
  t.numeric = {false, false, true, false, true};
  for (std::size_t i = 0; i < n; ++i) {
    const Letter& l = letters[i];
    if (!object.is_object() || !object.contains(l.key)) continue;
    t.rows.push_back(
        {l.symbol, l.name, Fixed(object[l.key], 3), "µm", ExpandedU(results, prefix + l.key)});
  }
  return t;
}

// The air and the material during the test.
render::ReportTable ConditionsTable(const json& results) {
  render::ReportTable t;
  t.header = {"Condition", "Value", "Unit"};
  t.numeric = {false, true, false};
  const json air = results.value("air", json::object());
  const json material = results.value("material", json::object());
  const auto row = [&](const json& o, const char* key, const std::string& label, const char* fmt,
                       const char* unit) {
    if (o.is_object() && o.contains(key)) t.rows.push_back({label, Plain(o[key], fmt), unit});
  };
  row(air, "air_temperature_c", "Air temperature", "%.2f", "°C");
  row(air, "air_pressure_pa", "Air pressure", "%.0f", "Pa");
  row(air, "air_humidity_pct", "Air humidity (relative)", "%.1f", "%");
  row(air, "co2_ppm", "CO₂ content of the air", "%.0f", "ppm");
  row(air, "laser_wavelength_nm", "Laser wavelength (vacuum)", "%.3f", "nm");
  row(air, "refractive_index", "Refractive index of the air", "%.9g", "");
  row(material, "material_temperature_c", "Material temperature", "%.2f", "°C");
  row(material, "reference_temperature_c", "Reference temperature", "%.2f", "°C");
  row(material, "expansion_ppm_per_k", "Expansion coefficient", "%.2f", "ppm/K");
  return t;
}

// The corrections of the readings, each with its size at the end of the axis.
render::ReportTable CorrectionsTable(const json& results) {
  render::ReportTable t;
  t.header = {"Correction of the readings", "Applied", "At the end of the axis", "Unit"};
  t.numeric = {false, false, true, false};
  const auto row = [&](const char* key, const std::string& what) {
    const json o = results.value(key, json::object());
    if (!o.is_object() || o.empty()) return;
    const bool applied = o.value("applied", false);
    t.rows.push_back({what, applied ? "yes" : "no",
                      applied ? Fixed(o.value("correction_at_end_um", json()), 3) + " at " +
                                    Fixed(o.value("end_of_axis_mm", json()), 3) + " mm"
                              : "—",
                      applied ? "µm" : ""});
  };
  row("air", "Air: the laser wavelength in the air (refractive index)");
  row("material", "Material: the length at the reference temperature (expansion)");
  return t;
}

}  // namespace

std::vector<render::ReportBlock> PositioningBlocks(const json& r, const std::string& where) {
  std::vector<render::ReportBlock> out;
  if (!r.is_object()) return out;
  const json targets = r.value("targets", json::object());
  std::string test = "Axis " + r.value("axis", std::string("—")) + ": " +
                     Short(r.value("runs", json())) + " runs of " +
                     Short(r.value("target_count", json())) + " targets in both directions (" +
                     Short(r.value("readings", json())) + " readings), " +
                     r.value("cycle", std::string("linear")) + " cycle; ";
  test += r.value("iso230_2_compliant", false)
              ? "the test meets the conditions of ISO 230-2."
              : "the test does not meet every condition of ISO 230-2 (see the notes).";
  out.push_back(render::ParagraphBlock(test));
  out.push_back(render::HeadingBlock("Deviation chart"));
  out.push_back(render::ChartBlock(DeviationChart(targets)));
  out.push_back(render::HeadingBlock("Figures (ISO 230-2:2014)"));
  out.push_back(render::ParagraphBlock(
      "↑: approach towards + (positive direction), ↓: towards −. U: the expanded uncertainty of "
      "the figure with its coverage factor k, from the input uncertainties the file states "
      "(\"not stated\": none propagated)."));
  out.push_back(render::TableBlock(LetterTable(r, r, kIso, std::size(kIso), "")));
  if (r.contains("vdi3441") && r["vdi3441"].is_object()) {
    out.push_back(render::HeadingBlock("Figures (VDI/DGQ 3441)"));
    out.push_back(
        render::TableBlock(LetterTable(r, r["vdi3441"], kVdi, std::size(kVdi), "vdi3441.")));
  }
  if (r.contains("uncertainty")) {
    for (auto& b : UncertaintyBlocks(r["uncertainty"], " of the figures")) {
      out.push_back(std::move(b));
    }
  }
  out.push_back(render::HeadingBlock("Conditions of the measurement"));
  out.push_back(render::TableBlock(ConditionsTable(r)));
  const json air = r.value("air", json::object());
  if (air.is_object() && air.contains("equation") && air["equation"].is_string()) {
    out.push_back(render::ParagraphBlock("The refractive index of the air from the " +
                                         air["equation"].get<std::string>() + "."));
  }
  const render::ReportTable corrections = CorrectionsTable(r);
  if (!corrections.rows.empty()) out.push_back(render::TableBlock(corrections));
  for (auto& b : ColumnTable(targets,
                             {{"target_mm", "Target (mm)"},
                              {"mean_up_um", "x̄↑ (µm)"},
                              {"s_up_um", "s↑ (µm)"},
                              {"mean_down_um", "x̄↓ (µm)"},
                              {"s_down_um", "s↓ (µm)"},
                              {"mean_bidirectional_um", "x̄ (µm)"},
                              {"reversal_um", "B (µm)"},
                              {"repeatability_um", "R (µm)"}},
                             "targets", where)) {
    out.push_back(std::move(b));
  }
  return out;
}

// The R-test of a trunnion table's rotary axes (docs/formats.md §3.18): the eight location
// errors with σ, the rank and condition of the pose set, what the poses do not determine in
// words, the RMS before and after the fit and the displacement per pose, measured and residual.
namespace {

// |v| of a 3-vector of numbers, NaN otherwise.
double Norm3(const json& v) {
  if (!v.is_array() || v.size() != 3) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (const auto& c : v) {
    if (!c.is_number()) return std::numeric_limits<double>::quiet_NaN();
    sum += c.get<double>() * c.get<double>();
  }
  return std::sqrt(sum);
}

render::ReportTable LocationErrorTable(const json& errors) {
  render::ReportTable t;
  t.header = {"Location error (ISO 230-1)", "Value", "σ", "Unit"};
  t.numeric = {false, true, true, false};
  if (!errors.is_object()) return t;
  // ISO 230-1's order: the tilt axis (A of an AC table, B of a BC one), then C.
  static const char* const kOrder[] = {"YOA_um", "ZOA_um", "BOA_urad", "COA_urad",
                                       "XOB_um", "ZOB_um", "AOB_urad", "COB_urad",
                                       "XOC_um", "YOC_um", "AOC_urad", "BOC_urad"};
  for (const char* key : kOrder) {
    if (!errors.contains(key)) continue;
    const json& e = errors[key];
    const bool known = e.is_object() && e.value("identifiable", false);
    t.rows.push_back({FigureName(key),
                      known ? Fixed(e.value("value", json()), 2) : "not determined",
                      known ? Sigma(e.value("sigma", json())) : "—", LabelOf(key).unit});
  }
  return t;
}

render::ReportChart PoseChart(const json& residuals) {
  render::ReportChart c;
  c.title = "Sphere displacement per pose: measured and after the fit";
  c.x_label = "Pose (file order)";
  c.y_label = "Length of the displacement (µm)";
  render::ReportSeries measured{"measured", {}, {}};
  render::ReportSeries residual{"residual (measured − model)", {}, {}};
  for (std::size_t i = 0; residuals.is_array() && i < residuals.size(); ++i) {
    const double x = static_cast<double>(i + 1);
    measured.x.push_back(x);
    measured.y.push_back(Norm3(residuals[i].value("measured_um", json())));
    residual.x.push_back(x);
    residual.y.push_back(Norm3(residuals[i].value("residual_um", json())));
  }
  c.series = {measured, residual};
  return c;
}

}  // namespace

std::vector<render::ReportBlock> RotaryBlocks(const json& r, const std::string& where) {
  std::vector<render::ReportBlock> out;
  const std::string sphere = Short(r.value("sphere_mm", json()));
  out.push_back(render::ParagraphBlock(
      r.value("kinematics", std::string("trunnion")) + " table, sphere at " + sphere + " mm; " +
      Short(r.value("poses", json())) + " poses, " + Short(r.value("observations", json())) +
      " readings. The location errors are those of the exact model of the two rotary axes "
      "fitted to the sphere's displacement at every pose (Gauss–Newton); σ is each error's "
      "standard uncertainty from the residual."));
  out.push_back(render::HeadingBlock("Location errors"));
  out.push_back(render::TableBlock(LocationErrorTable(r.value("location_errors", json()))));
  const json cond = r.value("condition", json());
  out.push_back(render::ParagraphBlock(
      "Rank of the pose set: " + Short(r.value("rank", json())) + " of " +
      Short(r.value("parameters", json(8))) + " errors; condition " +
      (cond.is_number() ? Fixed(cond, 1) : std::string("— (no error determined)")) +
      (r.value("converged", true) ? "." : "; the identification did not converge.")));
  const json groups = r.value("not_separable", json::array());
  if (groups.is_array() && !groups.empty()) {
    out.push_back(render::HeadingBlock("What these poses do not determine"));
    for (const auto& g : groups) {
      out.push_back(render::ParagraphBlock(g.value("sentence", std::string()) + "."));
    }
  }
  out.push_back(render::HeadingBlock("Residual"));
  render::ReportTable t;
  t.header = {"Figure", "Value", "Unit"};
  t.numeric = {false, true, false};
  t.rows = {
      {"RMS of the readings (before the fit)", Fixed(r.value("measured_rms_um", json()), 3), "µm"},
      {"RMS of the residual (after the fit)", Fixed(r.value("residual_rms_um", json()), 3), "µm"},
      {"Standard deviation of one reading s", Fixed(r.value("sigma_um", json()), 3), "µm"},
      {"Reading uncertainty stated in the file", Fixed(r.value("u_reading_um", json()), 3), "µm"}};
  out.push_back(render::TableBlock(std::move(t)));
  out.push_back(render::HeadingBlock("Displacement per pose"));
  out.push_back(render::ChartBlock(PoseChart(r.value("residuals", json::array()))));
  out.push_back(render::ParagraphBlock(
      "The displacement of every pose, measured and residual, is in " + where + "."));
  return out;
}

}  // namespace km::usecases::report_text
