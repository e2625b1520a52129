// The PDF reports of an accuracy audit and of a calibration or discovery job, and the audit
// section of a measurement report (usecases/pdf_reports.h).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "usecases/pdf_reports.h"
#include "usecases/pdf_reports_text.h"

namespace km::usecases {

using nlohmann::json;
using render::HeadingBlock;
using render::ParagraphBlock;
using render::ReportTable;
using render::TableBlock;
using report_text::Fixed;
using report_text::Short;

std::string AuditLevelWords(int level) {
  switch (level) {
    case 1:
      return "level 1 — normal";
    case 2:
      return "level 2 — warn";
    case 3:
      return "level 3 — stop";
    default:
      return "level " + std::to_string(level);
  }
}

namespace {

// The unit of a rule's metric ("circularity_um" → "µm"; "" when the metric does not say it).
std::string UnitOf(const json& rule) {
  const std::string unit = report_text::LabelOf(rule.value("metric", "")).unit;
  return unit.empty() ? "" : " " + unit;
}

// A limit with at most 3 decimals and no trailing zeros: "7.5", "20".
std::string LimitValue(const json& v) {
  std::string s = Fixed(v, 3);
  if (s.find('.') != std::string::npos) {
    s.erase(s.find_last_not_of('0') + 1);
    if (s.ends_with('.')) s.pop_back();
  }
  return s;
}

std::string Limits(const json& rule) {
  std::string s;
  const std::string unit = UnitOf(rule);
  if (rule.contains("warn") && rule["warn"].is_number())
    s += "warn " + LimitValue(rule["warn"]) + unit;
  if (rule.contains("stop") && rule["stop"].is_number()) {
    s += (s.empty() ? "" : ", ") + std::string("stop ") + LimitValue(rule["stop"]) + unit;
  }
  const std::string change = rule.value("change", "");
  if (change == "previous_audit") s = "increase since the previous audit: " + s;
  if (change == "days") s = "increase over " + Short(rule.value("days", json())) + " days: " + s;
  return s;
}

std::string Status(const json& c) {
  const std::string st = c.value("status", "");
  if (st == "finding") return AuditLevelWords(c.value("level", 0));
  if (st == "ok") return "within limits";
  return "not evaluated" +
         (c.contains("reason") ? ": " + report_text::Readable(Short(c["reason"])) : std::string());
}

std::string Evidence(const json& x) {
  if (x.contains("job_id") && !x["job_id"].is_null()) return "job #" + Short(x["job_id"]);
  if (x.contains("measurement_id") && !x["measurement_id"].is_null()) {
    return "measurement #" + Short(x["measurement_id"]);
  }
  return "—";
}

// The set-up a report is about: every set-up (a machine's audit report), or one measurement's.
struct SetUpFilter {
  std::string kind;  // "": every kind
  bool one = false;
  std::string test_id, direction;
};

// Whether a checked entry judged the filter's set-up (a pair figure: the test_id's pair).
bool JudgedSetUp(const json& c, const SetUpFilter& f) {
  if (!f.one || !c.contains("test_id")) return true;
  const std::string direction = c.value("direction", "");
  return c.value("test_id", "") == f.test_id && (direction.empty() || direction == f.direction);
}

std::string SetUpCell(const json& c) {
  if (c.value("status", "") == "stale") {
    return c.value("set_up", "") + " (stale, " + c.value("measured_at", "") + ")";
  }
  return c.value("set_up", "—");
}

// "DBB circularity F (least squares)" for a rule's kind and metric.
std::string RuleName(const json& rule) {
  const std::string kind = rule.value("kind", "");
  return (kind == "dbb" ? std::string("DBB") : report_text::Capitalised(kind)) + " " +
         report_text::FigureName(rule.value("metric", ""));
}

// "on request" or "scheduled": what started an audit.
std::string TriggerWords(const json& v) {
  const std::string trigger = v.value("trigger", "");
  if (trigger == "schedule") return "scheduled";
  if (trigger == "manual" || trigger.empty()) return "on request";
  return report_text::Readable(trigger);
}

// The rows of a rule: one per set-up it judged (of the filter's set-up only, when it is one).
void RuleRows(const json& rule, std::size_t i, const json& checked, const SetUpFilter& f,
              ReportTable& t, std::vector<std::size_t>& finding_rows) {
  const std::string what = RuleName(rule);
  bool any = false;
  for (const auto& c : checked) {
    if (c.value("rule", -1) != static_cast<int>(i) || !JudgedSetUp(c, f)) continue;
    any = true;
    if (c.value("status", "") == "finding") finding_rows.push_back(t.rows.size());
    t.rows.push_back(
        {what, SetUpCell(c), Limits(rule), c.contains("value") ? Fixed(c["value"], 3) : "—",
         c.value("status", "") == "stale" ? "stale: not judged" : Status(c), Evidence(c)});
  }
  if (!any) {
    t.rows.push_back({what, f.one ? f.test_id : "—", Limits(rule), "—",
                      checked.empty() ? "not run yet" : "not judged in this set-up", "—"});
  }
}

// One row a rule and set-up: what it limits, its limits, the newest audit's value and status;
// the rows with a finding are added to `finding_rows`.
ReportTable RulesTable(const json& rules, const json& verdict, const SetUpFilter& f,
                       std::vector<std::size_t>& finding_rows) {
  ReportTable t;
  t.header = {"Rule", "Set-up", "Limits", "Value", "Status", "Judged"};
  t.numeric = {false, false, false, true, false, false};
  const json checked = verdict.is_object() ? verdict.value("checked", json::array()) : json();
  for (std::size_t i = 0; i < rules.size(); ++i) {
    if (!f.kind.empty() && rules[i].value("kind", "") != f.kind) continue;
    RuleRows(rules[i], i, checked.is_array() ? checked : json::array(), f, t, finding_rows);
  }
  return t;
}

std::string VerdictLine(const json& v) {
  if (!v.is_object()) return "No audit has run yet.";
  return "Verdict: " + AuditLevelWords(v.value("level", 0)) + " (audit #" +
         Short(v.value("id", json())) + " of " + v.value("created_at", "") + ", " +
         TriggerWords(v) + ").";
}

// The rules table, at most report_text::kMaxTextTableRows rows, keeping the rules with a finding.
std::vector<render::ReportBlock> BoundedRules(const json& rules, const json& verdict,
                                              const SetUpFilter& f, const std::string& machine_id) {
  std::vector<std::size_t> findings;
  ReportTable t = RulesTable(rules, verdict, f, findings);
  return report_text::BoundedTable(std::move(t),
                                   {"rules", report_text::AuditAt(machine_id), std::move(findings),
                                    "rules with a finding", report_text::kMaxTextTableRows});
}

}  // namespace

namespace report_text {

std::string AuditAt(const std::string& machine_id) {
  return "the machine's audit rules (GET /api/v1/machines/" + machine_id +
         "/audit) and its audits (GET /api/v1/audits?machine_id=" + machine_id + ")";
}

std::vector<render::ReportBlock> AuditBlocks(const ReportAudit& audit, const ReportSource& source) {
  const std::string& kind = source.kind;
  const std::string& machine_id = source.machine_id;
  std::vector<render::ReportBlock> out;
  out.push_back(HeadingBlock("Accuracy audit of the machine"));
  const json rules =
      audit.config.is_object() ? audit.config.value("rules", json::array()) : json::array();
  if (rules.empty()) {
    out.push_back(ParagraphBlock("No audit rules are set for this machine."));
    return out;
  }
  out.push_back(ParagraphBlock(VerdictLine(audit.verdict)));
  const SetUpFilter f{kind, true, source.test_id, source.direction};
  auto table = BoundedRules(rules, audit.verdict, f, machine_id);
  if (table.front().table.rows.empty()) {
    out.push_back(ParagraphBlock("No rule of the machine's audit reads " + kind + " results."));
  } else {
    for (auto& b : table) out.push_back(std::move(b));
  }
  return out;
}

}  // namespace report_text

namespace {

// The findings of an audit, at most report_text::kMaxTextTableRows, keeping the highest level.
std::vector<render::ReportBlock> FindingsTable(const json& findings, const std::string& where) {
  ReportTable f;
  f.header = {"Level", "Finding", "Evidence"};
  int highest = 0;
  for (const auto& x : findings) highest = std::max(highest, x.value("level", 0));
  std::vector<std::size_t> keep;
  for (const auto& x : findings) {
    if (x.value("level", 0) == highest) keep.push_back(f.rows.size());
    f.rows.push_back({AuditLevelWords(x.value("level", 0)),
                      report_text::Readable(x.value("message", "")), Evidence(x)});
  }
  return report_text::BoundedTable(
      std::move(f), {"findings", where, std::move(keep), "findings of the highest level",
                     report_text::kMaxTextTableRows});
}

// The set-ups whose newest test is older than the audit's max_age_days: listed, not judged.
void StaleBlocks(render::Report& r, const json& verdict, const std::string& machine_id) {
  if (!verdict.is_object() || !verdict.contains("max_age_days")) return;
  const json stale = verdict.value("stale", json::array());
  r.blocks.push_back(
      HeadingBlock("Set-ups not measured within " + Short(verdict["max_age_days"]) + " days"));
  if (stale.empty()) {
    r.blocks.push_back(ParagraphBlock("None: every set-up judged was measured within that age."));
    return;
  }
  r.blocks.push_back(ParagraphBlock(
      verdict.value("stale_policy", "") == "warn"
          ? "Each is a level 2 finding of the audit: measure it again."
          : "They are listed, not judged: their newest values no longer describe the machine."));
  ReportTable t;
  t.header = {"Kind", "Set-up", "Last measured", "Age (days)", "Evidence"};
  t.numeric = {false, false, false, true, false};
  for (const auto& x : stale) {
    t.rows.push_back({x.value("kind", ""), x.value("set_up", ""), x.value("measured_at", ""),
                      Fixed(x.value("age_days", json()), 1), Evidence(x)});
  }
  for (auto& b : report_text::BoundedTable(
           std::move(t), report_text::Evenly("stale set-ups", report_text::AuditAt(machine_id),
                                             report_text::kMaxTextTableRows))) {
    r.blocks.push_back(std::move(b));
  }
}

}  // namespace

render::Report AuditPdfReport(const std::string& machine_id, const json& config,
                              const json& verdicts, const std::string& printed_at) {
  const json newest = verdicts.is_array() && !verdicts.empty() ? verdicts[0] : json();
  render::Report r;
  r.title = "Accuracy audit — " + machine_id;
  r.identification = {
      {"Machine", machine_id},
      {"Level",
       newest.is_object() ? AuditLevelWords(newest.value("level", 0)) : "no audit run yet"},
      {"Newest audit", newest.is_object() ? "#" + Short(newest.value("id", json())) + " of " +
                                                newest.value("created_at", "")
                                          : "—"},
      {"Schedule", config.is_object() && config.value("schedule", json()).is_string()
                       ? config.value("schedule", "")
                       : "on request only"},
      {"Rules updated", config.is_object() ? config.value("updated_at", "—") : "—"}};
  r.footer = report_text::Footer("audit report " + machine_id, printed_at);
  r.complete_at = report_text::AuditAt(machine_id);
  const json rules = config.is_object() ? config.value("rules", json::array()) : json::array();
  r.blocks.push_back(HeadingBlock("Rules, values and levels"));
  if (rules.empty()) {
    r.blocks.push_back(ParagraphBlock("No audit rules are set for this machine."));
  } else {
    r.blocks.push_back(ParagraphBlock(VerdictLine(newest)));
    for (auto& b : BoundedRules(rules, newest, SetUpFilter{}, machine_id)) {
      r.blocks.push_back(std::move(b));
    }
  }
  r.blocks.push_back(HeadingBlock("Findings of the newest audit"));
  const json findings = newest.is_object() ? newest.value("findings", json::array()) : json();
  if (findings.empty()) {
    r.blocks.push_back(ParagraphBlock("No findings: every evaluated rule is within its limits."));
  } else {
    for (auto& b : FindingsTable(findings, r.complete_at)) r.blocks.push_back(std::move(b));
  }
  StaleBlocks(r, newest, machine_id);
  r.blocks.push_back(HeadingBlock("History"));
  ReportTable h;
  h.header = {"Audit", "When", "Trigger", "Level", "Findings"};
  for (std::size_t i = 0; verdicts.is_array() && i < verdicts.size() && i < 50; ++i) {
    const json& v = verdicts[i];
    h.rows.push_back({"#" + Short(v.value("id", json())), v.value("created_at", ""),
                      TriggerWords(v), AuditLevelWords(v.value("level", 0)),
                      std::to_string(v.value("findings", json::array()).size())});
  }
  r.blocks.push_back(TableBlock(std::move(h)));
  r.blocks.push_back(HeadingBlock("Signatures"));
  r.blocks.push_back(render::SignatureBlock({"Audited by", "Approved by"}));
  return r;
}

namespace {

// A figure of a job report to 3 significant digits, whole numbers from 100 up (as the job's
// verdict reasons print them): "0.0801", "12.3", "178483"; "—" when missing or not finite.
std::string Sig3(const json& v) {
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  if (!v.is_number()) return "—";
  const double x = v.get<double>();
  if (!std::isfinite(x)) return "—";
  const double a = std::fabs(x);
  if (a >= 99.95 || a == 0.0) return Fixed(x, 0);
  if (a < 1e-3) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.2e", x);
    return buf;
  }
  int decimals = 2 - static_cast<int>(std::floor(std::log10(a)));
  const double rounded = std::round(a * std::pow(10.0, decimals)) / std::pow(10.0, decimals);
  decimals = 2 - static_cast<int>(std::floor(std::log10(rounded)));  // 9.996 → "10.0"
  return Fixed(x, std::max(decimals, 0));
}

// A value to the decimals of its σ (2 significant digits, report_text::Sigma), else Sig3.
std::string ValueTo(const json& value, const json& sigma) {
  if (!value.is_number()) return "—";
  if (!sigma.is_number() || !(sigma.get<double>() > 0) || !std::isfinite(sigma.get<double>())) {
    return Sig3(value);
  }
  const std::string s = report_text::Sigma(sigma);
  const auto dot = s.find('.');
  return Fixed(value, dot == std::string::npos ? 0 : static_cast<int>(s.size() - dot - 1));
}

std::string SigmaText(const json& sigma) {
  return sigma.is_number() ? report_text::Sigma(sigma) : "—";
}

// Effect names as words, alone or in a sentence: "servo_mismatch" → "servo mismatch".
std::string EffectWords(const std::string& name) {
  return report_text::Readable(name);
}

// Rows Quantity | Value | σ | Unit of a value that is a number or an array of numbers (one row a
// component, named by `parts`, e.g. the plane's axes "XY"); one "—" with the reason when absent.
void ValueRows(ReportTable& t, const std::string& name, const json& value, const json& sigma,
               const std::string& unit, const std::string& parts) {
  if (value.is_number()) {
    t.rows.push_back({name, ValueTo(value, sigma), SigmaText(sigma), unit});
    return;
  }
  if (!value.is_array() || value.empty()) {
    t.rows.push_back({name + " (not estimated)", "—", "", ""});
    return;
  }
  for (std::size_t i = 0; i < value.size(); ++i) {
    const json s = sigma.is_array() && i < sigma.size() ? sigma[i] : json();
    const std::string part =
        value.size() == parts.size() ? std::string(1, parts[i]) : std::to_string(i + 1);
    ValueRows(t, name + " " + part, value[i], s, unit, parts.size() == 3 ? parts : "xyz");
  }
}

// The kinematic parameters of a hexapod ({strut_offset_um[6], base_joint_offset_um[6][3]}) with
// their σ of the same shape: one row a strut, and a base joint's x, y and z.
void KinematicRows(ReportTable& t, const json& params, const json& sigma) {
  if (!params.is_object()) return;
  std::vector<std::string> keys;  // the struts first, then the base joints and any other
  for (const auto& [key, v] : params.items()) {
    keys.insert(key == "strut_offset_um" ? keys.begin() : keys.end(), key);
  }
  for (const auto& key : keys) {
    const auto l = report_text::LabelOf(key);
    const json s = sigma.is_object() && sigma.contains(key) ? sigma[key] : json();
    ValueRows(t, l.label, params[key], s, l.unit, "");
  }
}

// A discovery: its verdict, each step's added effect and the gap before and after it, as a
// table and a chart.
void DiscoverySteps(render::Report& r, const json& result) {
  const json steps = result.value("steps", json::array());
  if (result.contains("verdict") && result["verdict"].is_string()) {
    std::string verdict = "Verdict of the study: " + result["verdict"].get<std::string>();
    if (result.contains("stop_reason") && result["stop_reason"].is_string()) {
      verdict += " — " + EffectWords(result["stop_reason"].get<std::string>());
    }
    r.blocks.push_back(ParagraphBlock(verdict + "."));
  }
  r.blocks.push_back(HeadingBlock("Steps: the effect added and the gap it closed"));
  ReportTable t;
  t.header = {"Step", "Effect added", "Gap before (µm)", "Gap after (µm)", "Evidence"};
  t.numeric = {true, false, true, true, false};
  render::ReportChart c;
  c.title = "The gap between model and measurement, step by step";
  c.x_label = "step";
  c.y_label = "gap rms (µm)";
  render::ReportSeries gap{"gap rms", {}, {}};
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const json& s = steps[i];
    const json ev = s.value("evidence", json::object());
    t.rows.push_back({std::to_string(i + 1), EffectWords(s.value("added_effect", "")),
                      Sig3(s.value("gap_rms_before_um", json())),
                      Sig3(s.value("gap_rms_after_um", json())),
                      EffectWords(ev.is_object() ? ev.value("sentence", "") : "")});
    if (i == 0) {
      gap.x.push_back(0);
      gap.y.push_back(s.value("gap_rms_before_um", 0.0));
    }
    gap.x.push_back(static_cast<double>(i + 1));
    gap.y.push_back(s.value("gap_rms_after_um", 0.0));
  }
  if (t.rows.empty()) t.rows.push_back({"—", "no effect added", "", "", ""});
  for (auto& b : report_text::BoundedTable(
           std::move(t),
           report_text::Evenly("steps", r.complete_at, report_text::kMaxTextTableRows))) {
    r.blocks.push_back(std::move(b));
  }
  c.series.push_back(std::move(gap));
  if (result.contains("noise_floor_um") && result["noise_floor_um"].is_number()) {
    c.limits.push_back({"noise floor", result["noise_floor_um"].get<double>()});
  }
  if (!steps.empty()) r.blocks.push_back(render::ChartBlock(std::move(c)));
}

// The fitted values with their σ: a discovery's final model, a calibration's parameters and
// effects.
void FittedValues(render::Report& r, const json& result) {
  r.blocks.push_back(HeadingBlock("Fitted values"));
  ReportTable t;
  t.header = {"Quantity", "Value", "σ", "Unit"};
  t.numeric = {false, true, true, false};
  const std::string plane =
      result.value("plane", json()).is_string() ? result.value("plane", "") : std::string();
  for (const auto& m : result.value("final_model", json::array())) {
    const std::string name = EffectWords(m.value("effect", ""));
    if (m.contains("value")) {
      ValueRows(t, name, m["value"], m.value("sigma", json()), m.value("unit", ""), plane);
    } else if (m.contains("parameters")) {
      KinematicRows(t, m["parameters"], m.value("uncertainty", json()));
    }
  }
  KinematicRows(t, result.value("parameters", json::object()),
                result.value("parameter_uncertainty_um", json::object()));
  for (const auto& e : result.value("effects", json::array())) {
    if (!e.is_object()) continue;
    const json u = e.value("uncertainty", json::object());
    const json p = e.value("parameters", json::object());
    for (const auto& [key, v] : p.items()) {
      const auto l = report_text::LabelOf(key);
      ValueRows(t, EffectWords(e.value("effect", "")) + ": " + l.label, v,
                u.is_object() && u.contains(key) ? u[key] : json(), l.unit, "");
    }
  }
  if (t.rows.empty()) t.rows.push_back({"no fitted value in the result", "", "", ""});
  for (auto& b : report_text::BoundedTable(std::move(t),
                                           report_text::Evenly("fitted values", r.complete_at))) {
    r.blocks.push_back(std::move(b));
  }
}

// Rows Figure | Value | Unit of the numbers (and arrays of up to 3 numbers) and yes/no answers of
// a result and of its objects one level down, to 3 significant digits.
void FigureRows(ReportTable& t, const json& object, const std::string& prefix, int depth) {
  static const std::vector<std::string> kSkip = {
      "parameters", "parameter_uncertainty_um", "steps",          "final_model",
      "effects",    "calibrated_machine",       "updated_machine"};
  for (const auto& [key, v] : object.items()) {
    if (std::find(kSkip.begin(), kSkip.end(), key) != kSkip.end() && depth == 0) continue;
    const auto l = report_text::LabelOf(key);
    const std::string name = prefix + l.label;
    if (v.is_boolean()) {
      t.rows.push_back({name, v.get<bool>() ? "yes" : "no", ""});
    } else if (v.is_number()) {
      t.rows.push_back({name, Sig3(v), l.unit});
    } else if (v.is_array() && !v.empty() && v.size() <= 3 &&
               std::all_of(v.begin(), v.end(), [](const json& x) { return x.is_number(); })) {
      std::string s = "(";
      for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + Sig3(v[i]);
      t.rows.push_back({name, s + ")", l.unit});
    } else if (v.is_object() && depth < 1) {
      FigureRows(t, v, name + ": ", depth + 1);
    }
  }
}

// The machine a job is of: the job's machine_id (GET /api/v1/jobs/{id}), else the one its
// request or its result names.
std::string JobMachine(const json& job, const json& request, const json& result) {
  for (const json* o : {&job, &request, &result}) {
    if (o->is_object() && o->contains("machine_id") && (*o)["machine_id"].is_string() &&
        !(*o)["machine_id"].get<std::string>().empty()) {
      return (*o)["machine_id"].get<std::string>();
    }
  }
  return "— (not recorded with the job)";
}

// "Discovery — done"; a job not finished says its stage too: "Calibration — running
// (calibrating)".
std::string JobState(const json& job, bool discovery) {
  const std::string status =
      job.value("status", json()).is_string() ? job.value("status", "") : std::string("unknown");
  const std::string stage =
      job.value("stage", json()).is_string() ? job.value("stage", "") : std::string();
  std::string s = std::string(discovery ? "Discovery" : "Calibration") + " — " + status;
  if (!stage.empty() && stage != status && status != "done" && status != "cancelled") {
    s += " (" + stage + ")";
  }
  return s;
}

std::string MeasurementList(const json& request) {
  const json ids = request.is_object() ? request.value("measurement_ids", json()) : json();
  if (!ids.is_array() || ids.empty()) return "—";
  std::string s;
  for (const auto& id : ids) s += (s.empty() ? "#" : ", #") + Short(id);
  return s;
}

}  // namespace

render::Report JobPdfReport(const json& job, const std::string& printed_at) {
  const std::string kind = job.value("kind", "");
  const bool discovery = kind.find("discovery") != std::string::npos;
  const json request = job.value("request", json::object());
  const json result = job.value("result", json::object());
  const std::string status =
      job.value("status", json()).is_string() ? job.value("status", "") : std::string();
  const bool finished = status == "done" || status == "failed" || status == "cancelled";
  render::Report r;
  r.title = std::string(discovery ? "Model-gap discovery" : "Hexapod calibration") + " — job #" +
            Short(job.value("id", json()));
  r.identification = {{"Machine", JobMachine(job, request, result)},
                      {"Job", JobState(job, discovery)},
                      {"Verdict", job.contains("verdict") && job["verdict"].is_string()
                                      ? job["verdict"].get<std::string>()
                                      : "—"},
                      {"Submitted", job.value("created_at", "")},
                      {finished ? "Finished" : "Last updated", job.value("updated_at", "")},
                      {"Measurements", MeasurementList(request)}};
  r.footer = report_text::Footer("job report #" + Short(job.value("id", json())), printed_at);
  r.complete_at = "the job's result (GET /api/v1/jobs/" + Short(job.value("id", json())) + ")";
  const json reasons = job.value("verdict_reasons", json::array());
  for (std::size_t i = 0; i < reasons.size() && i < report_text::kMaxNotes; ++i) {
    r.blocks.push_back(ParagraphBlock(EffectWords(Short(reasons[i]))));
  }
  if (reasons.size() > report_text::kMaxNotes) {
    r.blocks.push_back(ParagraphBlock(std::to_string(report_text::kMaxNotes) + " of " +
                                      std::to_string(reasons.size()) +
                                      " reasons shown; every reason is in " + r.complete_at + "."));
  }
  if (job.contains("error") && job["error"].is_string()) {
    r.blocks.push_back(ParagraphBlock("Error: " + job["error"].get<std::string>()));
  }
  if (result.is_object() && !result.empty()) {
    if (discovery) DiscoverySteps(r, result);
    FittedValues(r, result);
    r.blocks.push_back(HeadingBlock("Figures"));
    ReportTable figures;
    figures.header = {"Figure", "Value", "Unit"};
    figures.numeric = {false, true, false};
    FigureRows(figures, result, "", 0);
    for (auto& b : report_text::BoundedTable(std::move(figures),
                                             report_text::Evenly("figures", r.complete_at))) {
      r.blocks.push_back(std::move(b));
    }
  }
  r.blocks.push_back(HeadingBlock("Signatures"));
  // A discovery is an analysis a second person reviews; a calibration is signed by who
  // calibrated the machine.
  r.blocks.push_back(
      render::SignatureBlock(discovery ? std::vector<std::string>{"Analysed by", "Reviewed by"}
                                       : std::vector<std::string>{"Calibrated by", "Approved by"}));
  return r;
}

}  // namespace km::usecases
