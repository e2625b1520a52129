// Endpoints of the PDF reports (server/reports/report_service.h): a measurement, a calibration
// or discovery job, a machine's accuracy audit, each one PDF document a viewer may read
// (api/endpoints.h).
#include "api/endpoints.h"
#include "api/route_util.h"

namespace km::api::endpoints {
namespace {

json PdfResponse() {
  return {{"200",
           {{"description", "PDF document (text selectable; vector graphics)"},
            {"content",
             {{"application/pdf", {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}}}};
}

// The file name a browser saves the report under: letters, digits, '.', '-' and '_' of `name`
// (anything else, from a machine id in the path, becomes '_').
Response Pdf(std::string bytes, std::string name) {
  for (auto& c : name) {
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                       c == '.' || c == '-' || c == '_';
    if (!plain) c = '_';
  }
  Response r;
  r.content_type = "application/pdf";
  r.body = std::move(bytes);
  r.headers["Content-Disposition"] = "inline; filename=\"" + name + ".pdf\"";
  return r;
}

}  // namespace

Endpoint MeasurementReportPdf(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "The report of a measurement as a PDF a lab signs: set-up, plot, figures, "
      "diagnosis, the machine's audit rules and verdict, as found / as left",
      [svc](const Request& req) {
        const auto id = req.PathId("id");
        return Pdf(svc->reports().MeasurementPdf(id),
                   "kinemetric-measurement-" + std::to_string(id));
      },
      {{"responses", PdfResponse()}}};
}

Endpoint JobReportPdf(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "The report of a calibration or discovery job as a PDF: the steps, the gap "
      "shrinking, the fitted values with their σ",
      [svc](const Request& req) {
        const auto id = req.PathId("id");
        return Pdf(svc->reports().JobPdf(id), "kinemetric-job-" + std::to_string(id));
      },
      {{"responses", PdfResponse()}}};
}

Endpoint AuditReportPdf(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "The accuracy audit of a machine as a PDF: every rule, value, level and "
      "finding, and the history of verdicts",
      [svc](const Request& req) {
        const auto& machine = req.path_params.at("machine_id");
        return Pdf(svc->reports().AuditPdf(machine), "kinemetric-audit-" + machine);
      },
      {{"responses", PdfResponse()}}};
}

}  // namespace km::api::endpoints
