// Routes of the servo-load analyses (docs/formats.md §5): identification of a hexapod's masses
// and friction from stored servo measurements (optionally saved as the next version of its
// model), joint resistance and health, and the external force of one stored record
// (api/endpoints.h). The work is done by the service (server/servo/servo_service.h).
#include <limits>

#include "api/endpoints.h"
#include "api/route_util.h"
#include "server/servo/servo_service.h"

namespace km::api::endpoints {
namespace {

json ServoRequestBody(bool identify) {
  json props = {{"machine_id", {{"type", "string"}}},
                {"machine_version", {{"type", "integer"}}},
                {"measurement_ids", {{"type", "array"}, {"items", {{"type", "integer"}}}}}};
  if (identify) {
    props["save"] = {{"type", "boolean"}};
    props["note"] = {{"type", "string"}};
  } else {
    for (const char* k : {"level2_ratio", "level3_ratio", "increase_warn", "increase_stop"}) {
      props[k] = {{"type", "number"}};
    }
    props["previous"] = {{"type", "object"}};
  }
  return JsonRequestBody({{"type", "object"},
                          {"required", json::array({"machine_id", "measurement_ids"})},
                          {"properties", props}});
}

}  // namespace

Endpoint ServoIdentify(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Hexapod masses and friction from stored servo measurements (docs/formats.md §3.10); "
      "\"save\": true stores them as the next version of the machine's model",
      [svc](const Request& req) { return Response::Json(svc->servo().Identify(JsonBody(req))); },
      {{"requestBody", ServoRequestBody(true)},
       {"responses",
        {{"200", JsonResponse("{identified{}, uncertainty{}, residual_rms_N[], "
                              "condition_number, fixed[], saved?}")}}}},
      kStudyRequestBytes};
}

Endpoint ServoJoints(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Joint resistance per leg and health levels 1/2/3 from stored CW and CCW servo "
      "measurements (docs/formats.md §3.12)",
      [svc](const Request& req) { return Response::Json(svc->servo().Joints(JsonBody(req))); },
      {{"requestBody", ServoRequestBody(false)},
       {"responses",
        {{"200", JsonResponse("{legs[{leg, resistance_Nm, sigma_Nm, level, "
                              "evidence}], level}")}}}},
      kStudyRequestBytes};
}

Endpoint JointHealth(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "The machine's stored joint-health estimates, oldest first, with the limits of "
      "the newest (docs/formats.md §5)",
      [svc](const Request& req) {
        return Response::Json(svc->servo().JointHealth(req.path_params.at("machine_id")));
      },
      {{"responses",
        {{"200", JsonResponse("{machine_id, limits, estimates[{result_id, "
                              "measurement_ids[], estimated_at, legs[], level}]}")}}}}};
}

Endpoint StreamServo(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "A stretch of a stream (feed-drive position and force channels) stored as a "
      "kinemetric-servo/1 measurement (docs/formats.md §5)",
      [svc](const Request& req) {
        const auto out = svc->servo().FromStream(req.PathId<server::StreamId>("id"), JsonBody(req));
        return Response::Json({{"id", out.id}, {"kind", out.kind}, {"created", out.created}},
                              out.created ? 201 : 200);
      },
      {{"requestBody",
        {{"required", true},
         {"content", {{"application/json", {{"schema", {{"type", "object"}}}}}}}}},
       {"responses", {{"201", JsonResponse("{id, kind: servo, created}")}}}},
      kSmallRequestBytes};
}

Endpoint ServoForce(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "External tool-tip force of a stored hexapod servo record with its machine's model "
      "(docs/formats.md §3.11)",
      [svc](const Request& req) {
        std::optional<std::int64_t> version;
        if (req.Query("machine_version")) {
          version =
              QueryInt(req, "machine_version", 1, 1, std::numeric_limits<std::int64_t>::max());
        }
        return Response::Json(svc->servo().Force(req.PathId<server::MeasurementId>("id"), version));
      },
      {{"parameters", json::array({Param("machine_version", "integer",
                                         "a stored version of the model (default: the newest)")})},
       {"responses", {{"200", JsonResponse("{t_s[], force_N[][3], sigma_N[][3], ...}")}}}}};
}

}  // namespace km::api::endpoints
