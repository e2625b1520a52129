// Routes of the accuracy audits (docs/http.md "Accuracy audits"): a machine's rules and
// schedule, a run on request, the stored verdicts and the metrics rules may name. The work is
// done by the service (server/audits/audit_service.h, server/audits/audit_scheduler.h).
#include <limits>

#include "api/route_util.h"
#include "api/routes.h"
#include "server/audits/audit_scheduler.h"
#include "server/audits/audit_service.h"

namespace km::api {
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

void AddConfigRoutes(Router& router, server::Service* svc) {
  Route put{"PUT",
            "/api/v1/machines/{machine_id}/audit",
            "Store the machine's accuracy-audit rules and schedule (levels 1 normal, 2 warn, "
            "3 stop)",
            true,
            [svc](const Request& req) {
              const auto out =
                  svc->audits().PutConfig(req.path_params.at("machine_id"), JsonBody(req));
              return Response::Json(out);
            },
            {{"requestBody", AuditBody()},
             {"responses",
              {{"200", JsonResponse("{machine_id, schedule, rules[], updated_at, last_run_at, "
                                    "next_run_at}")}}}}};
  put.max_body_bytes = 256u << 10;
  router.Add(std::move(put));
  router.Add(Route{"GET",
                   "/api/v1/machines/{machine_id}/audit",
                   "The machine's accuracy-audit rules and schedule (404 when it has none)",
                   true,
                   [svc](const Request& req) {
                     return Response::Json(
                         server::AuditConfigJson(*svc, req.path_params.at("machine_id")));
                   },
                   {{"responses",
                     {{"200", JsonResponse("{machine_id, schedule, rules[], updated_at, "
                                           "last_run_at, next_run_at}")}}}}});
  Route run{"POST",
            "/api/v1/machines/{machine_id}/audit/run",
            "Run the machine's accuracy audit now over its newest results; the verdict",
            true,
            [svc](const Request& req) {
              return Response::Json(svc->audits().Run(req.path_params.at("machine_id"), "manual"),
                                    201);
            },
            {{"responses", {{"201", JsonResponse(kVerdictKeys)}}}}};
  run.max_body_bytes = 4096;
  router.Add(std::move(run));
}

}  // namespace

void AddAuditRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;
  AddConfigRoutes(router, svc);
  router.Add(Route{
      "GET",
      "/api/v1/audits",
      "Accuracy-audit verdicts, newest first",
      true,
      [svc](const Request& req) {
        server::AuditVerdictFilter f;
        if (const auto m = req.Query("machine_id")) f.machine_id = *m;
        f.from = QueryTime(req, "from");
        f.to = QueryTime(req, "to");
        f.limit = QueryInt(req, "limit", 100, 1, 1000);
        return Response::Json(server::ListAccuracyAudits(*svc, f));
      },
      {{"parameters", json::array({Param("machine_id", "string", "one machine's verdicts"),
                                   Param("from", "string", "ISO 8601, inclusive (created_at)"),
                                   Param("to", "string", "ISO 8601, exclusive"),
                                   Param("limit", "integer", "1 to 1000 (default 100)")})},
       {"responses", {{"200", JsonResponse(std::string("{audits[") + kVerdictKeys + "]}")}}}}});
  router.Add(Route{"GET",
                   "/api/v1/audits/{id}",
                   "One accuracy-audit verdict with its findings and evidence",
                   true,
                   [svc](const Request& req) {
                     return Response::Json(server::AccuracyAuditJson(*svc, req.PathId("id")));
                   },
                   {{"responses", {{"200", JsonResponse(kVerdictKeys)}}}}});
  router.Add(Route{"GET",
                   "/api/v1/audit-metrics",
                   "The metrics accuracy-audit rules may name, by kind, with unit and source",
                   true,
                   [](const Request&) { return Response::Json(server::AuditMetricsJson()); },
                   {{"responses",
                     {{"200", JsonResponse("{metrics[{kind, metric, analysis, unit, "
                                           "description, source}]}")}}}}});
}

}  // namespace km::api
