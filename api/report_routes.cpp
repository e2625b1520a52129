// Endpoints of the PDF reports (server/reports/report_service.h): a measurement, a calibration
// or discovery job, a machine's accuracy audit, each one PDF document a viewer may read
// (api/endpoints.h).
#include <limits>
#include <optional>

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

constexpr std::int64_t kMaxId = std::numeric_limits<std::int64_t>::max();

std::optional<std::int64_t> OptionalId(const Request& req, const std::string& key) {
  if (!req.Query(key)) return std::nullopt;
  return QueryInt(req, key, 0, 1, kMaxId);
}

std::optional<server::MeasurementId> AsLeft(const Request& req) {
  if (const auto id = OptionalId(req, "as_left")) return server::MeasurementId(*id);
  return std::nullopt;
}

// The revision an approval names: the body's {"revision": N} (optional; an empty body approves
// the current revision), or ?revision=N.
std::optional<std::int64_t> ApprovedRevision(const Request& req) {
  if (req.body.empty()) return OptionalId(req, "revision");
  const json body = JsonBody(req);
  if (!body.is_object()) throw InvalidInput("", 0, "request", "must be a JSON object");
  for (const auto& [key, v] : body.items()) {
    if (key != "revision") throw InvalidInput("", 0, key, "is not a key of an approval");
  }
  if (!body.contains("revision")) return std::nullopt;
  const json& r = body["revision"];
  if (!r.is_number_integer() || r.get<std::int64_t>() < 1) {
    throw InvalidInput("", 0, "revision", "must be a whole number from 1");
  }
  return r.get<std::int64_t>();
}

server::ReportApprover Approver(const Request& req) {
  const server::TokenId token = req.CallerToken();
  return {token, req.token_name.empty() ? "token " + to_string(token) : req.token_name};
}

json ReportParams(bool as_left) {
  json p = json::array({Param("revision", "integer",
                              "an earlier revision of the certificate (only approved revisions "
                              "are kept as printed)")});
  if (as_left) {
    p.push_back(Param("as_left", "integer",
                      "the measurement chosen as the machine as left: a later test of the same "
                      "set-up"));
  }
  return p;
}

json ApproveDoc() {
  return {{"requestBody",
           JsonRequestBody(
               {{"type", "object"}, {"properties", {{"revision", {{"type", "integer"}}}}}}, false)},
          {"responses",
           {{"200", JsonResponse("{certificate, subject, revision, approved_by, approved_at, "
                                 "token_id, pdf_bytes}")}}}};
}

}  // namespace

Endpoint MeasurementReportPdf(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "The report of a measurement as a PDF a lab signs: set-up, plot, figures, "
      "diagnosis, the machine's audit rules and verdict, as found / as left",
      [svc](const Request& req) {
        const auto id = req.PathId<server::MeasurementId>("id");
        const server::ReportRequest q{AsLeft(req), OptionalId(req, "revision")};
        return Pdf(svc->reports().MeasurementPdf(id, q), "kinemetric-measurement-" + to_string(id));
      },
      {{"parameters", ReportParams(true)}, {"responses", PdfResponse()}}};
}

Endpoint JobReportPdf(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "The report of a calibration or discovery job as a PDF: the steps, the gap "
      "shrinking, the fitted values with their σ",
      [svc](const Request& req) {
        const auto id = req.PathId<server::JobId>("id");
        return Pdf(svc->reports().JobPdf(id, OptionalId(req, "revision")),
                   "kinemetric-job-" + to_string(id));
      },
      {{"parameters", ReportParams(false)}, {"responses", PdfResponse()}}};
}

Endpoint AuditReportPdf(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "The accuracy audit of a machine as a PDF: every rule, value, level and "
      "finding, and the history of verdicts",
      [svc](const Request& req) {
        const auto& machine = req.path_params.at("machine_id");
        return Pdf(svc->reports().AuditPdf(machine, OptionalId(req, "revision")),
                   "kinemetric-audit-" + machine);
      },
      {{"parameters", ReportParams(false)}, {"responses", PdfResponse()}}};
}

Endpoint MeasurementReportRevisions(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"The revisions of a measurement's certificate, each with who approved it and when",
          [svc](const Request& req) {
            return Response::Json(svc->reports().MeasurementRevisions(
                req.PathId<server::MeasurementId>("id"), AsLeft(req)));
          },
          {{"parameters",
            json::array({Param("as_left", "integer", "the as-left test of the certificate")})}}};
}

Endpoint JobReportRevisions(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"The revisions of a job's certificate",
          [svc](const Request& req) {
            return Response::Json(svc->reports().JobRevisions(req.PathId<server::JobId>("id")));
          },
          {}};
}

Endpoint AuditReportRevisions(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"The revisions of a machine's audit certificate",
          [svc](const Request& req) {
            return Response::Json(svc->reports().AuditRevisions(req.path_params.at("machine_id")));
          },
          {}};
}

Endpoint ApproveMeasurementReport(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Approves the current revision of a measurement's certificate (engineer): who and when "
      "go into the audit log and onto the PDF, which is frozen",
      [svc](const Request& req) {
        return Response::Json(
            svc->reports().ApproveMeasurement(req.PathId<server::MeasurementId>("id"), AsLeft(req),
                                              ApprovedRevision(req), Approver(req)));
      },
      ApproveDoc(), kSmallRequestBytes};
}

Endpoint ApproveJobReport(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Approves the current revision of a finished job's certificate (engineer)",
          [svc](const Request& req) {
            return Response::Json(svc->reports().ApproveJob(req.PathId<server::JobId>("id"),
                                                            ApprovedRevision(req), Approver(req)));
          },
          ApproveDoc(), kSmallRequestBytes};
}

Endpoint ApproveAuditReport(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Approves the current revision of a machine's audit certificate (engineer)",
          [svc](const Request& req) {
            return Response::Json(svc->reports().ApproveAudit(
                req.path_params.at("machine_id"), ApprovedRevision(req), Approver(req)));
          },
          ApproveDoc(), kSmallRequestBytes};
}

}  // namespace km::api::endpoints
