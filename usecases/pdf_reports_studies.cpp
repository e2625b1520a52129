// The PDF reports of an accuracy audit and of a calibration or discovery job, and the audit
// section of a measurement report (usecases/pdf_reports.h).
#include <algorithm>
#include <cstddef>
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

// A discovery: each step's added effect and the gap before and after it, as a table and a chart.
void DiscoverySteps(render::Report& r, const json& result) {
  const json steps = result.value("steps", json::array());
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
    t.rows.push_back({std::to_string(i + 1), s.value("added_effect", ""),
                      Fixed(s.value("gap_rms_before_um", json()), 3),
                      Fixed(s.value("gap_rms_after_um", json()), 3), ev.value("sentence", "")});
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

// The fitted values with their σ: a discovery's final model, a calibration's parameters.
void FittedValues(render::Report& r, const json& result) {
  r.blocks.push_back(HeadingBlock("Fitted values"));
  ReportTable t;
  t.header = {"Quantity", "Value", "σ", "Unit"};
  t.numeric = {false, true, true, false};
  for (const auto& m : result.value("final_model", json::array())) {
    if (m.contains("value")) {
      t.rows.push_back({m.value("effect", ""), Fixed(m["value"], 4),
                        Fixed(m.value("sigma", json()), 4), m.value("unit", "")});
    } else if (m.contains("parameters")) {
      t.rows.push_back({m.value("effect", ""), Short(m["parameters"]),
                        Short(m.value("uncertainty", json())), ""});
    }
  }
  const json params = result.value("parameters", json::object());
  const json sigma = result.value("parameter_uncertainty_um", json::object());
  for (const auto& [key, v] : params.items()) {
    const auto l = report_text::LabelOf(key);
    for (std::size_t i = 0; v.is_array() && i < v.size(); ++i) {
      const json s = sigma.contains(key) && sigma[key].is_array() && i < sigma[key].size()
                         ? sigma[key][i]
                         : json();
      t.rows.push_back({l.label + " " + std::to_string(i + 1), Short(v[i]), Short(s), l.unit});
    }
  }
  if (t.rows.empty()) t.rows.push_back({"—", "", "", ""});
  for (auto& b : report_text::BoundedTable(std::move(t),
                                           report_text::Evenly("fitted values", r.complete_at))) {
    r.blocks.push_back(std::move(b));
  }
}

}  // namespace

render::Report JobPdfReport(const json& job, const std::string& printed_at) {
  const std::string kind = job.value("kind", "");
  const bool discovery = kind.find("discovery") != std::string::npos;
  const json request = job.value("request", json::object());
  const json result = job.value("result", json::object());
  render::Report r;
  r.title = std::string(discovery ? "Model-gap discovery" : "Hexapod calibration") + " — job #" +
            Short(job.value("id", json()));
  r.identification = {
      {"Machine", request.is_object() ? request.value("machine_id", "—") : "—"},
      {"Job", kind + ", " + job.value("status", "") + " (" + job.value("stage", "") + ")"},
      {"Verdict", job.contains("verdict") && job["verdict"].is_string()
                      ? job["verdict"].get<std::string>()
                      : "—"},
      {"Submitted", job.value("created_at", "")},
      {"Finished", job.value("updated_at", "")},
      {"Measurements",
       request.is_object() ? Short(request.value("measurement_ids", json())) : "—"}};
  r.footer = report_text::Footer("job report #" + Short(job.value("id", json())), printed_at);
  r.complete_at = "the job's result (GET /api/v1/jobs/" + Short(job.value("id", json())) + ")";
  const json reasons = job.value("verdict_reasons", json::array());
  for (std::size_t i = 0; i < reasons.size() && i < report_text::kMaxNotes; ++i) {
    r.blocks.push_back(ParagraphBlock(Short(reasons[i])));
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
    for (auto& b : report_text::BoundedTable(
             report_text::FiguresTable(
                 result, {"parameters", "parameter_uncertainty_um", "steps", "final_model"}),
             report_text::Evenly("figures", r.complete_at))) {
      r.blocks.push_back(std::move(b));
    }
  }
  r.blocks.push_back(HeadingBlock("Signatures"));
  r.blocks.push_back(render::SignatureBlock({"Calibrated by", "Approved by"}));
  return r;
}

}  // namespace km::usecases
