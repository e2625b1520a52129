// Endpoints of the accuracy audits (docs/http.md "Accuracy audits"): a machine's rules and
// schedule, a run on request, the stored verdicts and the metrics rules may name
// (api/endpoints.h). The work is done by the service (server/audits/audit_service.h,
// server/audits/audit_scheduler.h).
#include <limits>

#include "api/endpoints.h"
#include "api/route_util.h"
#include "server/audits/audit_scheduler.h"
#include "server/audits/audit_service.h"

namespace km::api::endpoints {
namespace {

json AuditBody() {
  json rule = {
      {"type", "object"},
      {"required", json::array({"kind", "metric"})},
      {"properties",
       {{"kind", {{"type", "string"}}},
        {"metric", {{"type", "string"}}},
        {"warn", {{"type", "number"}}},
        {"stop", {{"type", "number"}}},
        {"change", {{"type", "string"}, {"enum", json::array({"previous_audit", "days"})}}},
        {"days", {{"type", "integer"}}}}}};
  return JsonRequestBody({{"type", "object"},
                          {"required", json::array({"rules"})},
                          {"properties",
                           {{"schedule", {{"type", "string"}, {"nullable", true}}},
                            {"rules", {{"type", "array"}, {"maxItems", 200}, {"items", rule}}}}}});
}

const char* const kVerdictKeys =
    "{id, machine_id, level, created_at, trigger, findings[{rule, kind, metric, level, value, "
    "limit, measurement_id (job_id for kind calibration), measured_at, message}], checked[], "
    "webhook}";

}  // namespace

Endpoint PutAuditConfig(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Store the machine's accuracy-audit rules and schedule (levels 1 normal, 2 warn, "
      "3 stop)",
      [svc](const Request& req) {
        return Response::Json(
            svc->audits().PutConfig(req.path_params.at("machine_id"), JsonBody(req)));
      },
      {{"requestBody", AuditBody()},
       {"responses",
        {{"200", JsonResponse("{machine_id, schedule, rules[], updated_at, last_run_at, "
                              "next_run_at}")}}}},
      256u << 10};
}

Endpoint GetAuditConfig(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"The machine's accuracy-audit rules and schedule (404 when it has none)",
          [svc](const Request& req) {
            return Response::Json(server::AuditConfigJson(*svc, req.path_params.at("machine_id")));
          },
          {{"responses",
            {{"200", JsonResponse("{machine_id, schedule, rules[], updated_at, "
                                  "last_run_at, next_run_at}")}}}}};
}

Endpoint RunAudit(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Run the machine's accuracy audit now over its newest results; the verdict",
          [svc](const Request& req) {
            return Response::Json(svc->audits().Run(req.path_params.at("machine_id"), "manual"),
                                  201);
          },
          {{"responses", {{"201", JsonResponse(kVerdictKeys)}}}},
          4096};
}

Endpoint ListAudits(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Accuracy-audit verdicts, newest first",
      [svc](const Request& req) {
        server::AuditVerdictFilter f;
        if (const auto m = req.Query("machine_id")) f.machine_id = *m;
        f.from = QueryTime(req, "from");
        f.to = QueryTime(req, "to");
        f.limit = QueryInt(req, "limit", 100, 1, 1000);
        f.offset = QueryInt(req, "offset", 0, 0, std::int64_t{1} << 40);
        Response r;
        r.body = server::ListAccuracyAuditsText(*svc, f);
        return r;
      },
      {{"parameters", json::array({Param("machine_id", "string", "one machine's verdicts"),
                                   Param("from", "string", "ISO 8601, inclusive (created_at)"),
                                   Param("to", "string", "ISO 8601, exclusive"),
                                   Param("limit", "integer", "1 to 1000 (default 100)"),
                                   Param("offset", "integer", "verdicts to skip (next_offset)")})},
       {"responses",
        {{"200", JsonResponse(std::string("{audits[") + kVerdictKeys +
                              "], limit, offset, truncated (the page stopped at 4 MiB), "
                              "next_offset (null on the last page)}")}}}}};
}

Endpoint GetAudit(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"One accuracy-audit verdict with its findings and evidence",
          [svc](const Request& req) {
            return Response::Json(
                server::AccuracyAuditJson(*svc, req.PathId<server::AuditVerdictId>("id")));
          },
          {{"responses", {{"200", JsonResponse(kVerdictKeys)}}}}};
}

Endpoint AuditMetrics(const RouteContext&) {
  return {"The metrics accuracy-audit rules may name, by kind, with unit and source",
          [](const Request&) { return Response::Json(server::AuditMetricsJson()); },
          {{"responses",
            {{"200", JsonResponse("{metrics[{kind, metric, analysis, unit, "
                                  "description, source}]}")}}}}};
}

}  // namespace km::api::endpoints
