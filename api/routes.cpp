// The route table of the kinemetric API: one line a route, with its method, path, the least role
// a token needs (server/access/roles.h) and its endpoint (api/endpoints.h: the handler and its
// OpenAPI detail, in the file of its capability). GET /api/v1/openapi.json is made from it.
#include "api/routes.h"

#include <iterator>

#include "api/endpoints.h"
#include "api/route_util.h"

namespace km::api {
namespace {

using server::Role;
namespace ep = endpoints;

// clang-format off
constexpr RouteLine kRouteTable[] = {
  // method   path                                                role             endpoint
  {"GET",    "/healthz",                                          Role::kPublic,   ep::Health},
  {"GET",    "/api/v1/openapi.json",                              Role::kPublic,   ep::OpenApi},
  // Measurements (api/measurement_routes.cpp)
  {"POST",   "/api/v1/measurements",                              Role::kOperator, ep::UploadMeasurement},
  {"GET",    "/api/v1/measurements",                              Role::kViewer,   ep::ListMeasurements},
  {"GET",    "/api/v1/measurements/{id}",                         Role::kViewer,   ep::GetMeasurement},
  {"GET",    "/api/v1/measurements/{id}/results",                 Role::kViewer,   ep::MeasurementResults},
  {"GET",    "/api/v1/measurements/{id}/trace",                   Role::kViewer,   ep::DbbTrace},
  {"GET",    "/api/v1/measurements/{id}/pair",                    Role::kViewer,   ep::DbbPair},
  {"GET",    "/api/v1/measurements/{id}/reversal",                Role::kViewer,   ep::StraightnessReversal},
  {"GET",    "/api/v1/measurements/{id}/compensation",            Role::kViewer,   ep::PositioningCompensation},
  {"GET",    "/api/v1/measurements/{id}/plot.png",                Role::kViewer,   ep::DbbPlotPng},
  // Studies, jobs and machine definitions (api/study_routes.cpp)
  {"POST",   "/api/v1/calibrations",                              Role::kEngineer, ep::SubmitCalibration},
  {"GET",    "/api/v1/jobs/{id}",                                 Role::kViewer,   ep::GetJob},
  // Beyond the role, only the job's owner or an admin (StudyService::CancelJob).
  {"DELETE", "/api/v1/jobs/{id}",                                 Role::kEngineer, ep::CancelJob},
  {"GET",    "/api/v1/jobs",                                      Role::kViewer,   ep::ListJobs},
  {"GET",    "/api/v1/machines",                                  Role::kViewer,   ep::ListMachines},
  {"POST",   "/api/v1/machines",                                  Role::kEngineer, ep::StoreMachineDefinition},
  {"GET",    "/api/v1/machines/{machine_id}/definition",          Role::kViewer,   ep::GetMachineDefinition},
  {"GET",    "/api/v1/machines/{machine_id}/definitions",         Role::kViewer,   ep::ListMachineDefinitions},
  {"POST",   "/api/v1/discoveries",                               Role::kEngineer, ep::SubmitDiscovery},
  {"POST",   "/api/v1/jobs/{id}/save-machine",                    Role::kEngineer, ep::SaveJobMachine},
  // Streams and acquisition devices (api/stream_routes.cpp); devices poll hosts on the network,
  // so reading them is for admins too.
  {"POST",   "/api/v1/streams",                                   Role::kOperator, ep::CreateStream},
  {"POST",   "/api/v1/streams/{id}/frames",                       Role::kOperator, ep::SendFrames},
  {"GET",    "/api/v1/streams",                                   Role::kViewer,   ep::ListStreams},
  {"GET",    "/api/v1/streams/{id}",                              Role::kViewer,   ep::GetStream},
  {"GET",    "/api/v1/streams/{id}/samples",                      Role::kViewer,   ep::StreamSamples},
  {"GET",    "/api/v1/streams/{id}/gaps",                         Role::kViewer,   ep::StreamGaps},
  {"POST",   "/api/v1/streams/{id}/profile",                      Role::kOperator, ep::StreamProfile},
  {"GET",    "/api/v1/devices",                                   Role::kAdmin,    ep::ListDevices},
  {"POST",   "/api/v1/devices",                                   Role::kAdmin,    ep::AddDevice},
  {"DELETE", "/api/v1/devices/{name}",                            Role::kAdmin,    ep::RemoveDevice},
  // Servo loads (api/servo_routes.cpp)
  {"POST",   "/api/v1/servo/identify",                            Role::kEngineer, ep::ServoIdentify},
  {"POST",   "/api/v1/servo/joints",                              Role::kOperator, ep::ServoJoints},
  {"GET",    "/api/v1/machines/{machine_id}/joint-health",        Role::kViewer,   ep::JointHealth},
  {"POST",   "/api/v1/streams/{id}/servo",                        Role::kOperator, ep::StreamServo},
  {"GET",    "/api/v1/measurements/{id}/servo/force",             Role::kViewer,   ep::ServoForce},
  // Fleet and trends (api/fleet_routes.cpp)
  {"GET",    "/api/v1/fleet",                                     Role::kViewer,   ep::FleetOverview},
  {"GET",    "/api/v1/machines/{machine_id}/trends",              Role::kViewer,   ep::MachineTrends},
  // Accuracy audits (api/audit_routes.cpp)
  {"PUT",    "/api/v1/machines/{machine_id}/audit",               Role::kEngineer, ep::PutAuditConfig},
  {"GET",    "/api/v1/machines/{machine_id}/audit",               Role::kViewer,   ep::GetAuditConfig},
  {"POST",   "/api/v1/machines/{machine_id}/audit/run",           Role::kEngineer, ep::RunAudit},
  {"GET",    "/api/v1/audits",                                    Role::kViewer,   ep::ListAudits},
  {"GET",    "/api/v1/audits/{id}",                               Role::kViewer,   ep::GetAudit},
  {"GET",    "/api/v1/audit-metrics",                             Role::kViewer,   ep::AuditMetrics},
  // Tolerance tables (api/tolerance_routes.cpp)
  {"PUT",    "/api/v1/machines/{machine_id}/tolerances",          Role::kEngineer, ep::PutTolerances},
  {"GET",    "/api/v1/machines/{machine_id}/tolerances",          Role::kViewer,   ep::GetTolerances},
  // The instrument register (api/instrument_routes.cpp)
  {"PUT",    "/api/v1/instruments/{serial}",                      Role::kEngineer, ep::PutInstrument},
  {"GET",    "/api/v1/instruments/{serial}",                      Role::kViewer,   ep::GetInstrument},
  {"GET",    "/api/v1/instruments",                               Role::kViewer,   ep::ListInstruments},
  // PDF reports (api/report_routes.cpp)
  {"GET",    "/api/v1/measurements/{id}/report.pdf",              Role::kViewer,   ep::MeasurementReportPdf},
  {"GET",    "/api/v1/jobs/{id}/report.pdf",                      Role::kViewer,   ep::JobReportPdf},
  {"GET",    "/api/v1/machines/{machine_id}/audit/report.pdf",    Role::kViewer,   ep::AuditReportPdf},
  {"GET",    "/api/v1/measurements/{id}/report/revisions",        Role::kViewer,   ep::MeasurementReportRevisions},
  {"GET",    "/api/v1/jobs/{id}/report/revisions",                Role::kViewer,   ep::JobReportRevisions},
  {"GET",    "/api/v1/machines/{machine_id}/audit/report/revisions", Role::kViewer, ep::AuditReportRevisions},
  {"POST",   "/api/v1/measurements/{id}/report/approve",          Role::kEngineer, ep::ApproveMeasurementReport},
  {"POST",   "/api/v1/jobs/{id}/report/approve",                  Role::kEngineer, ep::ApproveJobReport},
  {"POST",   "/api/v1/machines/{machine_id}/audit/report/approve", Role::kEngineer, ep::ApproveAuditReport},
  // The caller, tokens and the audit log (api/access_routes.cpp)
  {"GET",    "/api/v1/whoami",                                    Role::kViewer,   ep::WhoAmI},
  {"POST",   "/api/v1/tokens",                                    Role::kAdmin,    ep::CreateToken},
  {"GET",    "/api/v1/tokens",                                    Role::kAdmin,    ep::ListTokens},
  {"DELETE", "/api/v1/tokens/{id}",                               Role::kAdmin,    ep::RevokeToken},
  {"GET",    "/api/v1/audit-log",                                 Role::kAdmin,    ep::AuditLog},
  // Operations (api/metrics.cpp)
  {"GET",    "/metrics",                                          Role::kViewer,   ep::OperationsMetrics},
};
// clang-format on

}  // namespace

namespace endpoints {

Endpoint Health(const RouteContext&) {
  return {"Liveness and readiness",
          [](const Request&) {
            return Response::Json({{"status", "ok"}});
          },
          {{"responses", {{"200", JsonResponse("the server is ready")}}}}};
}

Endpoint OpenApi(const RouteContext& c) {
  const Router* rt = &c.router;
  return {"This OpenAPI document",
          [rt](const Request&) { return Response::Json(OpenApiDocument(*rt, kApiVersion)); },
          {{"responses", {{"200", JsonResponse("OpenAPI 3 document")}}}}};
}

}  // namespace endpoints

void AddRoute(Router& router, const RouteContext& context, const RouteLine& line) {
  Endpoint e = line.endpoint(context);
  Route r{line.method,
          line.path,
          std::move(e.summary),
          line.role != Role::kPublic,
          std::move(e.handler),
          std::move(e.openapi),
          std::move(e.open_body),
          e.max_body_bytes,
          line.role};
  router.Add(std::move(r));
}

void AddRoutes(Router& router, server::Service& service) {
  const RouteContext context{service, router};
  for (const auto& line : kRouteTable) AddRoute(router, context, line);
}

std::string EnsureAdminToken(server::AccessStore& storage, const std::string& bootstrap) {
  return server::EnsureAdminToken(storage, bootstrap);
}

}  // namespace km::api
