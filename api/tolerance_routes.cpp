// Endpoints of the machines' tolerance tables (docs/http.md "Tolerances and conformance"): a
// new version of a machine's table, the newest or one version (api/endpoints.h). The work is
// done by the service (server/tolerances/tolerance_service.h); each measurement's conformance
// comes with the measurement routes.
#include "api/endpoints.h"
#include "api/route_util.h"

namespace km::api::endpoints {
namespace {

json ToleranceSchema() {
  return {{"type", "object"},
          {"required", json::array({"kind", "metric", "tolerance"})},
          {"properties",
           {{"kind", {{"type", "string"}}},
            {"metric", {{"type", "string"}}},
            {"tolerance", {{"type", "number"}, {"minimum", 0}}},
            {"test_id", {{"type", "string"}, {"description", "exact, or a pattern with *"}}},
            {"direction", {{"type", "string"}, {"enum", json::array({"cw", "ccw"})}}},
            {"axis", {{"type", "string"}}}}}};
}

const char* const kTableKeys = "{machine_id, version, tolerances[], created_at}";

}  // namespace

Endpoint PutTolerances(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Store the next version of the machine's tolerance table (the same entries as the "
      "newest version: that version, nothing stored)",
      [svc](const Request& req) {
        return Response::Json(
            svc->tolerances().Put(req.path_params.at("machine_id"), JsonBody(req)));
      },
      {{"requestBody",
        JsonRequestBody(
            {{"type", "object"},
             {"required", json::array({"tolerances"})},
             {"properties",
              {{"tolerances",
                {{"type", "array"}, {"maxItems", 200}, {"items", ToleranceSchema()}}}}}})},
       {"responses",
        {{"200", JsonResponse("{machine_id, version, tolerances[], created_at, created}")}}}},
      256u << 10};
}

Endpoint GetTolerances(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"The machine's tolerance table, the newest version or ?version=N (404 when none)",
          [svc](const Request& req) {
            std::optional<std::int64_t> version;
            if (req.Query("version")) {
              version = QueryInt(req, "version", 0, 1, std::int64_t{1} << 40);
            }
            return Response::Json(svc->tolerances().Get(req.path_params.at("machine_id"), version));
          },
          {{"parameters",
            json::array({Param("version", "integer", "a stored version (default: the newest)")})},
           {"responses", {{"200", JsonResponse(kTableKeys)}}}}};
}

}  // namespace km::api::endpoints
