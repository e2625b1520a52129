// Endpoints of the caller and of access (api/endpoints.h): who the caller is, access tokens
// (create, list, revoke; admin) and the audit log of state-changing requests (admin).
#include "api/endpoints.h"
#include "api/route_util.h"
#include "server/access/access.h"
#include "server/base/errors.h"

namespace km::api::endpoints {

Endpoint WhoAmI(const RouteContext&) {
  return {
      "The caller: its token's id, name and role (e.g. for a dashboard to hide what the role "
      "may not do)",
      [](const Request& req) {
        return Response::Json({{"token_id", server::IdOrNull(req.token_id)},
                               {"name", req.token_name},
                               {"role", req.RoleName()}});
      },
      {{"responses", {{"200", JsonResponse("{token_id, name, role}")}}}}};
}

Endpoint CreateToken(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Create an access token (the secret is shown only in this answer)",
      [svc](const Request& req) {
        Response r = Response::Json(svc->access().CreateToken(JsonBody(req)), 201);
        r.headers["Cache-Control"] = "no-store";
        return r;
      },
      {{"requestBody",
        JsonRequestBody({{"type", "object"},
                         {"required", json::array({"name", "role"})},
                         {"properties",
                          {{"name", {{"type", "string"}}},
                           {"role",
                            {{"type", "string"},
                             {"enum", json::array({"viewer", "operator", "engineer", "admin"})}}},
                           {"expires_in_s", {{"type", "integer"}, {"minimum", 1}}}}}})},
       {"responses", {{"201", JsonResponse("{id, token, name, role, expires_at}")}}}},
      4096};
}

Endpoint ListTokens(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Access tokens (never their secrets)",
          [svc](const Request&) { return Response::Json(svc->access().ListTokens()); },
          {{"responses",
            {{"200", JsonResponse("{items[{id, name, role, created_at, expires_at, "
                                  "revoked_at, state}]}")}}}}};
}

Endpoint RevokeToken(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Revoke an access token at once",
          [svc](const Request& req) {
            return Response::Json(svc->access().RevokeToken(req.PathId<server::TokenId>("id")));
          },
          {{"responses",
            {{"200", JsonResponse("{id, revoked_at}")},
             {"409", {{"description", "the last active admin token"}}}}}}};
}

Endpoint AuditLog(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Audit log of state-changing requests (who, what, when), newest first",
          [svc](const Request& req) {
            return Response::Json(
                svc->access().AuditLog(QueryInt(req, "limit", 100, 1, 1000),
                                       QueryInt(req, "offset", 0, 0, std::int64_t{1} << 40)));
          },
          {{"parameters", json::array({Param("limit", "integer", "1 to 1000 (default 100)"),
                                       Param("offset", "integer", "entries to skip")})},
           {"responses",
            {{"200", JsonResponse("{items[{id, at, token_id, token_name, role, method, path, "
                                  "status, subject}], total, limit, offset}")}}}}};
}

}  // namespace km::api::endpoints
