// What each route of the API does: an endpoint is its handler with the OpenAPI detail beside it
// (summary, parameters, request body, answers) and its body limit. The route table
// (api/routes.cpp) pairs each with its method, path and role, one line a route. The endpoints
// are grouped by capability, one file a group; each group below names its file.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "api/http.h"
#include "server/service.h"

namespace km::api {

// What an endpoint may use: the service, and the router (for the OpenAPI document).
struct RouteContext {
  server::Service& service;
  const Router& router;
};

struct Endpoint {
  std::string summary;
  std::function<Response(const Request&)> handler;
  nlohmann::json openapi = nullptr;  // operation object extras: parameters, requestBody, responses
  std::size_t max_body_bytes = 0;    // 0: the server's limit (api/http.h Route)
  BodySinkFactory open_body = nullptr;  // a body streamed as it arrives (api/http.h Route)
};

using EndpointFn = Endpoint (*)(const RouteContext&);

namespace endpoints {

// The server itself (api/routes.cpp).
Endpoint Health(const RouteContext& c);
Endpoint OpenApi(const RouteContext& c);

// Uploads, stored measurements and the DBB, straightness and positioning views recomputed from
// them (api/measurement_routes.cpp).
Endpoint UploadMeasurement(const RouteContext& c);
Endpoint ListMeasurements(const RouteContext& c);
Endpoint GetMeasurement(const RouteContext& c);
Endpoint MeasurementResults(const RouteContext& c);
Endpoint DbbTrace(const RouteContext& c);
Endpoint DbbPair(const RouteContext& c);
Endpoint StraightnessReversal(const RouteContext& c);
Endpoint PositioningCompensation(const RouteContext& c);
Endpoint DbbPlotPng(const RouteContext& c);

// Calibration and discovery studies as background jobs, the machines and their stored
// definitions (api/study_routes.cpp).
Endpoint SubmitCalibration(const RouteContext& c);
Endpoint GetJob(const RouteContext& c);
Endpoint CancelJob(const RouteContext& c);
Endpoint ListJobs(const RouteContext& c);
Endpoint ListMachines(const RouteContext& c);
Endpoint StoreMachineDefinition(const RouteContext& c);
Endpoint GetMachineDefinition(const RouteContext& c);
Endpoint ListMachineDefinitions(const RouteContext& c);
Endpoint SubmitDiscovery(const RouteContext& c);
Endpoint SaveJobMachine(const RouteContext& c);

// Capacitance-sensor streams and Modbus TCP devices (api/stream_routes.cpp).
Endpoint CreateStream(const RouteContext& c);
Endpoint SendFrames(const RouteContext& c);
Endpoint ListStreams(const RouteContext& c);
Endpoint GetStream(const RouteContext& c);
Endpoint StreamSamples(const RouteContext& c);
Endpoint StreamGaps(const RouteContext& c);
Endpoint StreamProfile(const RouteContext& c);
Endpoint ListDevices(const RouteContext& c);
Endpoint AddDevice(const RouteContext& c);
Endpoint RemoveDevice(const RouteContext& c);

// Servo-load analyses (api/servo_routes.cpp).
Endpoint ServoIdentify(const RouteContext& c);
Endpoint ServoJoints(const RouteContext& c);
Endpoint JointHealth(const RouteContext& c);
Endpoint StreamServo(const RouteContext& c);
Endpoint ServoForce(const RouteContext& c);

// The fleet overview and a machine's trends (api/fleet_routes.cpp).
Endpoint FleetOverview(const RouteContext& c);
Endpoint MachineTrends(const RouteContext& c);

// Accuracy audits (api/audit_routes.cpp).
Endpoint PutAuditConfig(const RouteContext& c);
Endpoint GetAuditConfig(const RouteContext& c);
Endpoint RunAudit(const RouteContext& c);
Endpoint ListAudits(const RouteContext& c);
Endpoint GetAudit(const RouteContext& c);
Endpoint AuditMetrics(const RouteContext& c);

// The machines' tolerance tables, versioned (api/tolerance_routes.cpp).
Endpoint PutTolerances(const RouteContext& c);
Endpoint GetTolerances(const RouteContext& c);

// The instrument register, versioned (api/instrument_routes.cpp).
Endpoint PutInstrument(const RouteContext& c);
Endpoint GetInstrument(const RouteContext& c);
Endpoint ListInstruments(const RouteContext& c);

// PDF reports (api/report_routes.cpp).
Endpoint MeasurementReportPdf(const RouteContext& c);
Endpoint JobReportPdf(const RouteContext& c);
Endpoint AuditReportPdf(const RouteContext& c);
Endpoint MeasurementReportRevisions(const RouteContext& c);
Endpoint JobReportRevisions(const RouteContext& c);
Endpoint AuditReportRevisions(const RouteContext& c);
Endpoint ApproveMeasurementReport(const RouteContext& c);
Endpoint ApproveJobReport(const RouteContext& c);
Endpoint ApproveAuditReport(const RouteContext& c);

// The caller, access tokens and the audit log (api/access_routes.cpp).
Endpoint WhoAmI(const RouteContext& c);
Endpoint CreateToken(const RouteContext& c);
Endpoint ListTokens(const RouteContext& c);
Endpoint RevokeToken(const RouteContext& c);
Endpoint AuditLog(const RouteContext& c);

// Operations metrics in the Prometheus text format (api/metrics.cpp).
Endpoint OperationsMetrics(const RouteContext& c);

}  // namespace endpoints
}  // namespace km::api
