// The routes of the kinemetric API: the route table (api/routes.cpp, one line a route: method,
// path, role, endpoint), the endpoints by capability (api/endpoints.h), and the access hooks.
// GET /api/v1/openapi.json lists them all.
#pragma once

#include "api/endpoints.h"
#include "api/http.h"
#include "server/access/roles.h"
#include "server/service.h"

namespace km::api {

inline constexpr const char* kApiVersion = "0.1.0";

// One line of the route table: method, path pattern, the least role a token needs
// (server::Role::kPublic: no token) and the endpoint (api/endpoints.h).
struct RouteLine {
  const char* method;
  const char* path;
  server::Role role;
  EndpointFn endpoint;
};

// Adds every route of the table (api/routes.cpp) to the router, each endpoint bound to the
// service.
void AddRoutes(Router& router, server::Service& service);
// Adds the route of one line, its endpoint bound to `context`: what AddRoutes does for every line
// of the table (docs/architecture.md "Recipe: a new HTTP route").
void AddRoute(Router& router, const RouteContext& context, const RouteLine& line);

// Access control (api/access.cpp): every route that needs a token checks `Authorization: Bearer
// TOKEN` against the stored token hashes (through the service; the Storage overload serves tests
// and tools): 401 without a valid (known, unexpired, unrevoked) token, 403 when the token's role
// is below RequiredRole(route). The caller is noted in the request.
RequestHook TokenHook(server::Service& service);
RequestHook TokenHook(server::AccessStore& storage);

// Records every state-changing request (not GET) with its caller, status and subject in the
// audit log; set with Router::SetObserver.
ResponseHook AuditHook(server::Service& service);

// First start: make sure an admin token exists. Uses `bootstrap` when given (the value of
// KINEMETRIC_BOOTSTRAP_TOKEN), else generates one; returns the new token text when one was
// created by generation (to be printed once), empty otherwise. The server calls
// AccessService::EnsureAdminToken; this form serves tests and tools holding a storage.
std::string EnsureAdminToken(server::AccessStore& storage, const std::string& bootstrap);

}  // namespace km::api
