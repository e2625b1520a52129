// The routes of the kinemetric API, added by capability: one Add…Routes function a file (listed
// below), each route with its method, path, role, handler and OpenAPI description (api/http.h
// Route). GET /api/v1/openapi.json lists them all.
#pragma once

#include "api/http.h"
#include "server/service.h"

namespace km::api {

inline constexpr const char* kApiVersion = "0.1.0";

// Adds the routes of the service to the router.
void AddRoutes(Router& router, server::Service& service);

// Machine definitions (versioned), discovery studies and saving a job's machine
// (api/routes.cpp).
void AddMachineModelRoutes(Router& router, server::Service& service);

// The capacitance-sensor stream and acquisition-device routes (api/stream_routes.cpp).
void AddStreamRoutes(Router& router, server::Service& service);

// The servo-load analyses of stored measurements (api/servo_routes.cpp).
void AddServoRoutes(Router& router, server::Service& service);

// Accuracy audits: rules and schedule of a machine, runs, verdicts, metrics
// (api/audit_routes.cpp).
void AddAuditRoutes(Router& router, server::Service& service);

// The fleet overview and a machine's trends (api/fleet_routes.cpp).
void AddFleetRoutes(Router& router, server::Service& service);

// PDF reports of a measurement, a job and a machine's audit (api/report_routes.cpp).
void AddReportRoutes(Router& router, server::Service& service);

// Tokens (create, list, revoke) and the audit log, all admin (api/access.cpp).
void AddAccessRoutes(Router& router, server::Service& service);

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
