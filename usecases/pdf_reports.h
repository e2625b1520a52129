// The content of the PDF reports a metrology lab signs (drawn by render/pdf_report.h), built from
// the same results the JSON answers hold, so a report and the API never disagree:
// - a DBB test (with its opposite-direction partner): set-up, the polar plot, the ISO 230-4
//   figures in tool-path units, the diagnosis, the machine's audit rules with their limits and
//   the newest verdict, as found / as left when a later test of the same set-up exists, a
//   signature block;
// - a form, tracker, positioning or servo result: its figures and tables;
// - an accuracy audit of a machine: every rule, value, level and finding, the history;
// - a calibration or discovery job: the steps, the gap shrinking, the fitted values with σ.
// The CLI writes the measurement reports of files; the service also adds what it stores (ids,
// audits, later tests).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/dbb/full_analysis.h"
#include "render/pdf_report.h"
#include "usecases/report_inputs.h"

namespace km::usecases {

struct ReportContext {
  std::string printed_at;  // ISO 8601 UTC
  std::optional<ReportAudit> audit;
  std::optional<ReportLater> later;
  std::optional<std::int64_t> partner_id;  // the stored partner of a DBB test
  // The measurement's conformance with its machine's tolerances ({verdict, tolerance_version,
  // figures}; docs/http.md "Tolerances and conformance"); null: not judged (the command line).
  nlohmann::json conformance = nullptr;
};

// A DBB test: test_index is the test of `report` the report is about (its pair partner, when the
// set holds one, is shown beside it); `report_json` is usecases::DbbReportJson of the same set.
render::Report DbbPdfReport(const dbb::DbbReport& report, const nlohmann::json& report_json,
                            std::size_t test_index, const ReportSource& source,
                            const ReportContext& context);

// Any other measurement: its result object (docs/formats.md §3) as figures and tables.
render::Report ResultsPdfReport(const nlohmann::json& results, const ReportSource& source,
                                const ReportContext& context);

// A machine's accuracy audit: config (rules, schedule; null: none) and its verdicts, newest
// first (docs/http.md).
render::Report AuditPdfReport(const std::string& machine_id, const nlohmann::json& config,
                              const nlohmann::json& verdicts, const std::string& printed_at);

// A calibration or discovery job as GET /api/v1/jobs/{id} answers it.
render::Report JobPdfReport(const nlohmann::json& job, const std::string& printed_at);

// The certificate number and revision under the title, and the approval (or that the revision
// is a draft) under the signatures.
void AddCertificate(render::Report& report, const ReportCertificate& certificate);

// "level 2 — warn" for an audit level.
std::string AuditLevelWords(int level);

}  // namespace km::usecases
