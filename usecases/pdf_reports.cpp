#include "usecases/pdf_reports.h"

#include <algorithm>
#include <cctype>
#include <cmath>
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

// The figures certified of a result: its uncertainty figures (ISO's first), else `fallback`.
std::vector<std::string> CertifiedKeys(const json& holder, std::vector<std::string> fallback) {
  const json figures =
      holder.is_object()
          ? holder.value("uncertainty", json::object()).value("figures", json::object())
          : json::object();
  if (!figures.is_object() || figures.empty()) return fallback;
  std::vector<std::string> keys;
  for (const auto& [key, f] : figures.items()) {
    if (f.is_object()) keys.push_back(key);
  }
  std::stable_sort(keys.begin(), keys.end(), [](const std::string& a, const std::string& b) {
    return report_text::FigureRank(a) < report_text::FigureRank(b);
  });
  return keys;
}

// A figure of a result by its key: the key itself, a path ("vdi3441.P_um") or the key inside one
// of the result's objects (a DBB test's "iso230_4"); null when the result does not hold it.
json FigureValue(const json& holder, const std::string& key) {
  if (!holder.is_object()) return nullptr;
  std::string path = "/" + key;
  std::replace(path.begin(), path.end(), '.', '/');
  const json::json_pointer p(path);
  if (holder.contains(p) && holder.at(p).is_number()) return holder.at(p);
  for (const auto& [k, v] : holder.items()) {
    if (v.is_object() && v.contains(key) && v[key].is_number()) return v[key];
  }
  return nullptr;
}

// Target | compensation as found (forward, reverse) | as left, in µm, for a laser test: the table
// loaded into the controller after the first test beside what remained after it.
std::vector<render::ReportBlock> CompensationBeforeAfter(const json& found, const json& left) {
  const json a = found.value("compensation", json::object());
  const json b = left.value("compensation", json::object());
  const json ta = a.value("target_mm", json::array());
  if (ta.empty()) return {};
  ReportTable t;
  t.header = {"Target (mm)", "As found fwd (µm)", "As found rev (µm)", "As left fwd (µm)",
              "As left rev (µm)"};
  t.numeric.assign(t.header.size(), true);
  const json tb = b.value("target_mm", json::array());
  for (std::size_t i = 0; i < ta.size(); ++i) {
    std::vector<std::string> row{Fixed(ta[i], 3), Fixed(a.value("forward_um", json::array())[i]),
                                 Fixed(a.value("reverse_um", json::array())[i])};
    std::size_t j = 0;
    while (j < tb.size() && !(tb[j].is_number() && ta[i].is_number() &&
                              std::abs(tb[j].get<double>() - ta[i].get<double>()) < 1e-6)) {
      ++j;
    }
    const bool has = j < tb.size();
    row.push_back(has ? Fixed(b.value("forward_um", json::array()).at(j)) : "—");
    row.push_back(has ? Fixed(b.value("reverse_um", json::array()).at(j)) : "—");
    t.rows.push_back(std::move(row));
  }
  return {HeadingBlock("Compensation tables, as found and as left"),
          ParagraphBlock("The correction per target (−mean deviation, ISO 230-2 order) of each "
                         "test: as found is the table derived before the adjustment, as left what "
                         "the second test still asks for."),
          TableBlock(std::move(t))};
}

std::vector<render::ReportBlock> AsFoundAsLeft(const json& found, const ReportLater& later,
                                               const ReportSource& source) {
  ReportTable t;
  t.header = {"Figure", "As found", "As left", "Unit"};
  t.numeric = {false, true, true, false};
  const json& after = later.results;
  t.rows.push_back({"Measurement", "#" + std::to_string(source.measurement_id.value_or(0)),
                    "#" + std::to_string(later.measurement_id), ""});
  t.rows.push_back({"Measured", report_text::When(source.measured_at),
                    report_text::When(later.measured_at), ""});
  for (const auto& key :
       CertifiedKeys(found, {"circularity_um", "min_zone_circularity_um", "average_radial_error_um",
                             "accuracy_um", "repeatability_um", "reversal_value_um"})) {
    const json a = FigureValue(found, key);
    const json b = FigureValue(after, key);
    if (a.is_null() && b.is_null()) continue;
    t.rows.push_back({report_text::Capitalised(report_text::FigureName(key)), Fixed(a, 3),
                      Fixed(b, 3), report_text::LabelOf(key).unit});
  }
  std::vector<render::ReportBlock> out{
      HeadingBlock("As found / as left"),
      ParagraphBlock("The two tests of one set-up chosen as the machine before and after its "
                     "adjustment."),
      TableBlock(std::move(t))};
  if (source.kind == "positioning") {
    for (auto& b : CompensationBeforeAfter(found, after)) out.push_back(std::move(b));
  }
  return out;
}

// The conformance entry of a figure (its metric's base name is the key), or null.
json ConformanceOf(const json& conformance, const std::string& key) {
  if (!conformance.is_object()) return nullptr;
  for (const auto& f : conformance.value("figures", json::array())) {
    const std::string m = f.value("metric", "");
    if (m.substr(0, m.find('.')) == key) return f;
  }
  return nullptr;
}

// A coverage factor as printed: "2", "2.26".
std::string Coverage(const json& k) {
  if (!k.is_number()) return "—";
  const double v = k.get<double>();
  return Fixed(v, v == std::round(v) ? 0 : 2);
}

// Figure | value | U | k | tolerance | decision | unit: each figure of the result with its
// expanded uncertainty and the decision against its tolerance under the rule in force.
std::vector<render::ReportBlock> CertifiedFigures(
    const std::vector<std::pair<std::string, const json*>>& holders, const json& conformance) {
  ReportTable t;
  t.header = {"Figure", "Value", "U", "k", "Tolerance", "Decision", "Unit"};
  t.numeric = {false, true, true, true, true, false, false};
  for (const auto& [label, holder] : holders) {
    const json figures =
        holder->value("uncertainty", json::object()).value("figures", json::object());
    for (const auto& key : CertifiedKeys(*holder, {})) {
      const json& f = figures[key];
      const json c = ConformanceOf(conformance, key);
      const json k = f.value("k", json(2));
      t.rows.push_back({report_text::Capitalised(report_text::FigureName(key)) + label,
                        Fixed(FigureValue(*holder, key), 3),
                        report_text::Sigma(f.value("U_um", json())), Coverage(k),
                        c.is_null() ? "—" : Fixed(c.value("tolerance", json()), 3),
                        c.is_null() ? "no tolerance" : c.value("verdict", std::string("—")), "µm"});
    }
  }
  if (t.rows.empty()) return {};
  return {HeadingBlock("Figures with their uncertainty and decision"),
          ParagraphBlock("U is the expanded uncertainty (coverage factor k, about 95 %) of each "
                         "figure, with two significant digits; the decision compares the value "
                         "with its tolerance under the "
                         "decision rule of the tolerance table (below)."),
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
                      U.is_number() ? report_text::Sigma(U) : std::string("not stated"),
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

void AddClosing(render::Report& r, const ReportSource& source, const ReportContext& context,
                const std::vector<std::pair<std::string, const json*>>& holders) {
  for (auto& b : CertifiedFigures(holders, context.conformance)) r.blocks.push_back(std::move(b));
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
  if (source.measurement_id) {
    return at + ", the compensation table also as CSV (GET /api/v1/measurements/" +
           std::to_string(*source.measurement_id) + "/compensation?format=csv)";
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
  std::vector<std::pair<std::string, const json*>> holders;
  for (const auto& x : shown) holders.push_back({" — " + Upper(x.value("direction", "")), &x});
  if (pair.is_object()) holders.push_back({" — pair", &pair});
  AddClosing(r, source, context, holders);
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
      {"rotary", "Rotary axes: location errors (R-test, ISO 10791-6)"},
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
    if (context.later) {
      for (auto& b : AsFoundAsLeft(results, *context.later, source)) {
        r.blocks.push_back(std::move(b));
      }
    }
    AddClosing(r, source, context, {{"", &results}});
    return r;
  }
  if (source.kind == "rotary") {
    for (auto& b : report_text::RotaryBlocks(results, r.complete_at)) {
      r.blocks.push_back(std::move(b));
    }
    json rest = results;  // the sentences of what the poses cannot separate are shown above
    if (rest.is_object() && rest.contains("warnings") && rest["warnings"].is_array()) {
      json kept = json::array();
      for (const auto& w : rest["warnings"]) {
        bool shown = false;
        for (const auto& g : results.value("not_separable", json::array())) {
          shown = shown || (g.is_object() && g.value("sentence", json()) == w);
        }
        if (!shown) kept.push_back(w);
      }
      rest["warnings"] = kept;
    }
    AddNotes(r, rest);
    AddClosing(r, source, context, {{"", &results}});
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
  if (context.later) {
    for (auto& b : AsFoundAsLeft(results, *context.later, source)) r.blocks.push_back(std::move(b));
  }
  AddClosing(r, source, context, {{"", &results}});
  return r;
}

void AddCertificate(render::Report& r, const ReportCertificate& c) {
  const std::string number = c.number + ", revision " + std::to_string(c.revision);
  const bool approved = !c.approved_by.empty();
  std::vector<std::pair<std::string, std::string>> head{
      {"Certificate", number},
      {"Approval", approved
                       ? "approved by " + c.approved_by + " at " + report_text::When(c.approved_at)
                       : "draft — revision " + std::to_string(c.revision) + " is not approved"}};
  if (!c.supersedes.empty()) head.push_back({"Supersedes", c.supersedes});
  r.identification.insert(r.identification.begin(), head.begin(), head.end());
  r.footer += " · certificate " + number + (approved ? " (approved)" : " (draft)");
  r.blocks.push_back(ParagraphBlock(
      approved ? "Approved by " + c.approved_by + " at " + report_text::When(c.approved_at) +
                     ", recorded in the service's audit log. This revision is frozen: a later "
                     "change to what it certifies makes a new revision, never an edit of this one."
               : "Draft: revision " + std::to_string(c.revision) + " of certificate " + c.number +
                     " is not approved. It becomes a certificate when an engineer approves it; a "
                     "later change to what it certifies makes a new revision."));
}

}  // namespace km::usecases
