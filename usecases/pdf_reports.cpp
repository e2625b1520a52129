#include "usecases/pdf_reports.h"

#include <cctype>
#include <string>
#include <utility>
#include <vector>

#include "render/dbb_plot.h"
#include "usecases/pdf_reports_text.h"

namespace km::usecases {
namespace {

using nlohmann::json;
using render::HeadingBlock;
using render::ParagraphBlock;
using render::ReportTable;
using render::TableBlock;
using report_text::Fixed;

std::string Upper(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

std::string Meta(const json& m, const char* key, const std::string& fallback = "—") {
  return m.contains(key) && m[key].is_string() ? m[key].get<std::string>() : fallback;
}

// A header value with its unit ("20.4 °C"), "—" alone when the file does not state it.
std::string MetaIn(const json& m, const char* key, const char* unit) {
  const std::string v = Meta(m, key);
  return v == "—" ? v : v + " " + unit;
}

// The set-up of the test as its file states it.
ReportTable SetUpTable(const json& test, const json& meta) {
  ReportTable t;
  t.header = {"Set-up", "Value"};
  t.rows = {{"Plane", test.value("plane", "XY")},
            {"Direction", Upper(test.value("direction", ""))},
            {"Bar length", Fixed(test.value("bar_length_mm", json()), 3) + " mm"},
            {"Circle radius", Fixed(test.value("radius_mm", json()), 3) + " mm"},
            {"Centre", MetaIn(meta, "centre_mm", "mm")},
            {"Feed", MetaIn(meta, "feed_mm_min", "mm/min")},
            {"Evaluation", report_text::Readable(test.value("mode", "")) + ", over " +
                               (test.value("evaluated_over", "") == "full_turn" ? "a full turn"
                                                                                : "a partial arc") +
                               " (" + Fixed(test.value("evaluated_arc_deg", json()), 0) + "°)"},
            {"Temperature", MetaIn(meta, "temperature_c", "°C")}};
  return t;
}

// Figure | CCW | CW | unit, in tool-path units (ISO 230-4), for the tests shown.
ReportTable FiguresOfTests(const std::vector<json>& tests, const json& pair) {
  ReportTable t;
  t.header = {"Figure"};
  for (const auto& x : tests) t.header.push_back(Upper(x.value("direction", "")));
  t.header.push_back("Unit");
  t.numeric.assign(t.header.size(), true);
  t.numeric.front() = false;
  t.numeric.back() = false;
  const auto row = [&](const std::string& label, auto get, const char* unit) {
    std::vector<std::string> r{label};
    for (const auto& x : tests) r.push_back(get(x));
    r.push_back(unit);
    t.rows.push_back(std::move(r));
  };
  const auto num = [](const char* key) {
    return [key](const json& x) { return Fixed(x.value(key, json())); };
  };
  row("Circularity F (least squares)", num("circularity_um"), "µm");
  row("Circularity, minimum zone", num("min_zone_circularity_um"), "µm");
  row(
      "Circular deviation G (ISO 230-4)",
      [](const json& x) {
        return Fixed(x.value("iso230_4", json::object()).value("circular_deviation_um", json()));
      },
      "µm");
  row(
      "Centre offset x",
      [](const json& x) {
        const auto c = x.value("centre_offset_um", json::array());
        return c.size() == 2 ? Fixed(c[0]) : std::string("—");
      },
      "µm");
  row(
      "Centre offset y",
      [](const json& x) {
        const auto c = x.value("centre_offset_um", json::array());
        return c.size() == 2 ? Fixed(c[1]) : std::string("—");
      },
      "µm");
  row("Average radial error", num("average_radial_error_um"), "µm");
  if (pair.is_object()) {
    const auto one = [&](const std::string& label, const char* key) {
      std::vector<std::string> r{label, Fixed(pair.value(key, json()))};
      r.resize(t.header.size() - 1);
      r.push_back("µm");
      t.rows.push_back(std::move(r));
    };
    one("Bidirectional circular deviation G(b) (pair)", "bidirectional_circular_deviation_um");
    one("Circular hysteresis H (pair)", "circular_hysteresis_um");
  }
  return t;
}

std::vector<render::ReportBlock> DiagnosisBlocks(const json& test, const std::string& where) {
  std::vector<render::ReportBlock> out;
  out.push_back(HeadingBlock("Diagnosis: the errors that make up the circle"));
  const auto& d = test.value("diagnosis", json::array());
  if (d.empty()) {
    out.push_back(ParagraphBlock("No effect stands out of the noise of this test."));
  } else {
    ReportTable t;
    t.header = {"Effect", "Value", "± σ", "Unit", "Share of circularity"};
    t.numeric = {false, true, true, false, true};
    for (const auto& e : d) {
      const json& v = e.contains("value") ? e["value"] : json();
      const json& u = e.contains("uncertainty") ? e["uncertainty"] : json();
      t.rows.push_back(
          {report_text::Capitalised(report_text::Readable(e.value("effect", ""))),
           v.is_array() ? report_text::Readable(report_text::Short(v)) : Fixed(v, 3),
           u.is_array() ? report_text::Readable(report_text::Short(u)) : report_text::Sigma(u),
           report_text::Readable(e.value("unit", "")),
           Fixed(e.value("contribution_pct", json()), 1) + " %"});
    }
    for (auto& b : report_text::BoundedTable(std::move(t), report_text::Evenly("effects", where))) {
      out.push_back(std::move(b));
    }
  }
  const auto& ni = test.value("not_identifiable", json::array());
  if (!ni.empty()) {
    std::string s = "Not identifiable from this test: ";
    for (std::size_t i = 0; i < ni.size(); ++i) {
      s += (i ? "; " : "") + report_text::Readable(report_text::Short(ni[i]));
    }
    out.push_back(ParagraphBlock(s + "."));
  }
  return out;
}

std::vector<render::ReportBlock> AsFoundAsLeft(const json& test, const ReportLater& later,
                                               const ReportSource& source) {
  ReportTable t;
  t.header = {"Figure", "As found", "As left", "Unit"};
  t.numeric = {false, true, true, false};
  const json& after = later.results;
  t.rows.push_back({"Measurement", "#" + std::to_string(source.measurement_id),
                    "#" + std::to_string(later.measurement_id), ""});
  t.rows.push_back({"Measured", report_text::When(source.measured_at),
                    report_text::When(later.measured_at), ""});
  for (const char* key : {"circularity_um", "min_zone_circularity_um", "average_radial_error_um"}) {
    t.rows.push_back({report_text::Capitalised(report_text::FigureName(key)),
                      Fixed(test.value(key, json())), Fixed(after.value(key, json())),
                      report_text::LabelOf(key).unit});
  }
  return {HeadingBlock("As found / as left"),
          ParagraphBlock("The newest later test of the same set-up (machine, test and "
                         "direction) is the machine as left."),
          TableBlock(std::move(t))};
}

// "test_id xy-r*, CW", "axis X", "every set-up" for an entry's scope keys in a figure.
std::string ScopeOf(const json& figure) {
  std::string out;
  const auto add = [&](const std::string& s) { out += (out.empty() ? "" : ", ") + s; };
  if (figure.contains("axis")) add("axis " + figure["axis"].get<std::string>());
  if (figure.contains("test_id")) add("test " + figure["test_id"].get<std::string>());
  if (figure.contains("direction")) add(Upper(figure["direction"].get<std::string>()));
  return out.empty() ? "every set-up" : out;
}

// The conformance with the tolerances: the table's version, each figure with its value,
// tolerance and verdict, and the overall verdict.
std::vector<render::ReportBlock> ConformanceBlocks(const json& c, const ReportSource& source) {
  std::vector<render::ReportBlock> out{HeadingBlock("Conformance with the tolerances")};
  const std::string verdict = c.value("verdict", "");
  const json& version = c.contains("tolerance_version") ? c["tolerance_version"] : json();
  if (!version.is_number_integer()) {
    out.push_back(ParagraphBlock("Machine " + source.machine_id +
                                 " has no tolerance table: verdict no tolerance."));
    return out;
  }
  const std::string table = "tolerance table version " + version.dump() + " of machine " +
                            source.machine_id + " (the newest when printed)";
  if (verdict == "no tolerance") {
    out.push_back(ParagraphBlock("No tolerance applies to this set-up in the " + table +
                                 ": verdict no tolerance."));
    return out;
  }
  ReportTable t;
  t.header = {"Figure", "Tolerance of", "Value", "U (k = 2)", "Tolerance", "Unit", "Verdict"};
  t.numeric = {false, false, true, true, true, false, false};
  for (const auto& f : c.value("figures", json::array())) {
    const json& U = f.contains("U") ? f["U"] : json();
    t.rows.push_back({report_text::Capitalised(report_text::FigureName(f.value("metric", ""))),
                      ScopeOf(f), Fixed(f.value("value", json()), 3),
                      U.is_number() ? Fixed(U, 3) : std::string("not stated"),
                      Fixed(f.value("tolerance", json()), 3), f.value("unit", ""),
                      f.value("verdict", "")});
  }
  const json rule = c.value("decision_rule", json::object());
  const std::string rule_text = rule.is_object() && rule.contains("description")
                                    ? rule["description"].get<std::string>()
                                    : std::string("simple acceptance: the value alone");
  out.push_back(
      ParagraphBlock("Judged against the " + table + ". Decision rule: " + rule_text + "."));
  out.push_back(TableBlock(std::move(t)));
  const char* why = verdict == "pass"        ? " — every figure is within its tolerance."
                    : verdict == "undecided" ? " — a figure is within its uncertainty (guard "
                                               "band) of its tolerance: neither conformance nor "
                                               "non-conformance is proven."
                                             : " — a figure is out of tolerance or the result "
                                               "does not hold it.";
  out.push_back(ParagraphBlock("Verdict: " + verdict + why));
  return out;
}

void AddClosing(render::Report& r, const ReportSource& source, const ReportContext& context) {
  if (context.conformance.is_object()) {
    for (auto& b : ConformanceBlocks(context.conformance, source)) r.blocks.push_back(std::move(b));
  }
  if (context.audit) {
    for (auto& b : report_text::AuditBlocks(*context.audit, source)) {
      r.blocks.push_back(std::move(b));
    }
  }
  r.blocks.push_back(HeadingBlock("Signatures"));
  r.blocks.push_back(render::SignatureBlock({"Measured by", "Checked by", "Approved by"}));
}

// Where the complete result of a measurement is; for a laser positioning test also its
// compensation table as CSV.
std::string CompleteAt(const ReportSource& source) {
  std::string at = report_text::ResultAt(source);
  if (source.kind != "positioning") return at;
  if (source.measurement_id > 0) {
    return at + ", the compensation table also as CSV (GET /api/v1/measurements/" +
           std::to_string(source.measurement_id) + "/compensation?format=csv)";
  }
  return at + ", the compensation table also as CSV (kinemetric positioning export " +
         source.filename + " --format csv)";
}

// The result's warnings, each a note, at most report_text::kMaxNotes of them.
void AddNotes(render::Report& r, const json& results) {
  if (!results.contains("warnings") || !results["warnings"].is_array()) return;
  const json& warnings = results["warnings"];
  for (std::size_t i = 0; i < warnings.size() && i < report_text::kMaxNotes; ++i) {
    r.blocks.push_back(
        ParagraphBlock("Note: " + report_text::Readable(report_text::Short(warnings[i]))));
  }
  if (warnings.size() > report_text::kMaxNotes) {
    r.blocks.push_back(ParagraphBlock(
        std::to_string(report_text::kMaxNotes) + " of " + std::to_string(warnings.size()) +
        " notes shown; every note is in the warnings of " + r.complete_at + "."));
  }
}

}  // namespace

render::Report DbbPdfReport(const dbb::DbbReport& report, const json& report_json,
                            std::size_t test_index, const ReportSource& source,
                            const ReportContext& context) {
  const json& tests = report_json.at("tests");
  const json& test = tests.at(test_index);
  std::vector<json> shown{test};
  json pair = nullptr;
  const auto& t = report.tests.at(test_index);
  if (t.pair) {
    const auto& p = report.pairs[*t.pair];
    shown = {tests.at(p.ccw), tests.at(p.cw)};
    pair = report_json.at("pairs").at(*t.pair);
  }
  render::Report r;
  r.title = "DBB circular test — " + source.machine_id + ", " + source.test_id + " " +
            Upper(source.direction);
  r.identification = report_text::Identification(source);
  if (context.partner_id) {
    r.identification.push_back(
        {"Partner", "measurement #" + std::to_string(*context.partner_id) + " (" +
                        Upper(source.direction == "cw" ? "ccw" : "cw") + ")"});
  }
  r.footer = report_text::Footer("DBB report " + source.machine_id, context.printed_at);
  r.complete_at = report_text::ResultAt(source);
  r.blocks.push_back(TableBlock(SetUpTable(test, source.metadata)));
  r.blocks.push_back(HeadingBlock("Polar plot"));
  // At the scale the page draws it (web/static/polar.js), its key figures in µm.
  const render::PolarScale scale = render::DbbPageScale(report, test_index);
  render::PolarPlotOptions plot;
  plot.um_per_div = scale.um_per_div;
  plot.divisions = scale.divisions;
  render::DbbPolar polar = render::DbbPolarPlot(report, test_index, plot);
  for (auto& note : polar.options.notes) note = report_text::Readable(note);
  r.blocks.push_back(render::PolarBlock(std::move(polar)));
  r.blocks.push_back(HeadingBlock("Figures (ISO 230-4, tool-path units)"));
  r.blocks.push_back(TableBlock(FiguresOfTests(shown, pair)));
  for (const auto& x : shown) {
    if (!x.contains("uncertainty")) continue;
    for (auto& b : report_text::UncertaintyBlocks(
             x["uncertainty"], " — " + Upper(x.value("direction", "")) + " test")) {
      r.blocks.push_back(std::move(b));
    }
  }
  if (pair.is_object() && pair.contains("uncertainty")) {
    for (auto& b : report_text::UncertaintyBlocks(pair["uncertainty"], " — CW/CCW pair")) {
      r.blocks.push_back(std::move(b));
    }
  }
  for (auto& b : DiagnosisBlocks(test, r.complete_at)) r.blocks.push_back(std::move(b));
  if (context.later) {
    for (auto& b : AsFoundAsLeft(test, *context.later, source)) r.blocks.push_back(std::move(b));
  }
  AddClosing(r, source, context);
  return r;
}

render::Report ResultsPdfReport(const json& results, const ReportSource& source,
                                const ReportContext& context) {
  static const std::vector<std::pair<std::string, std::string>> kTitles = {
      {"straightness", "Straightness"},
      {"flatness", "Flatness"},
      {"parallelism", "Parallelism"},
      {"tracker", "Laser-tracker self-calibration"},
      {"positioning", "Linear positioning (ISO 230-2)"},
      {"servo", "Servo loads"}};
  std::string what = source.kind;
  for (const auto& [k, v] : kTitles) {
    if (k == source.kind) what = v;
  }
  render::Report r;
  r.title =
      what + " — " + source.machine_id + (source.test_id.empty() ? "" : ", " + source.test_id);
  r.identification = report_text::Identification(source);
  r.footer = report_text::Footer(what + " report " + source.machine_id, context.printed_at);
  r.complete_at = CompleteAt(source);
  if (source.kind == "positioning") {
    for (auto& b : report_text::PositioningBlocks(results, r.complete_at)) {
      r.blocks.push_back(std::move(b));
    }
    AddNotes(r, results);
    AddClosing(r, source, context);
    return r;
  }
  r.blocks.push_back(HeadingBlock("Figures"));
  for (auto& b :
       report_text::BoundedTable(report_text::FiguresTable(results, {"uncertainty", "instrument"}),
                                 report_text::Evenly("figures", r.complete_at))) {
    r.blocks.push_back(std::move(b));
  }
  if (results.is_object() && results.contains("uncertainty")) {
    for (auto& b : report_text::UncertaintyBlocks(results["uncertainty"], " of the figures")) {
      r.blocks.push_back(std::move(b));
    }
  }
  for (auto& b : report_text::ColumnTables(results, r.complete_at)) {
    r.blocks.push_back(std::move(b));
  }
  AddNotes(r, results);
  AddClosing(r, source, context);
  return r;
}

}  // namespace km::usecases
