// Endpoints of the fleet overview and of a machine's trends (docs/formats.md §5): every machine
// with its newest measurement, open jobs and newest audit; one figure of a machine's stored
// results over time (api/endpoints.h). The work is done by the service
// (server/audits/fleet_service.h).
#include "api/endpoints.h"
#include "api/route_util.h"
#include "server/audits/fleet_service.h"

namespace km::api::endpoints {

Endpoint FleetOverview(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Every machine with its newest measurement, number of measurements, open jobs "
      "and newest accuracy audit",
      [svc](const Request&) { return Response::Json(server::Fleet(*svc)); },
      {{"responses",
        {{"200", JsonResponse("{machines[{machine_id, measurements, "
                              "last_measurement, open_jobs, audit}]}")}}}}};
}

Endpoint MachineTrends(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "One figure of the machine's stored results over time, oldest first (without metric: "
      "the metrics known)",
      [svc](const Request& req) {
        const auto metric = req.Query("metric");
        if (!metric) return Response::Json({{"metrics", server::TrendMetrics()}});
        return Response::Json(server::Trends(*svc, req.path_params.at("machine_id"), *metric));
      },
      {{"parameters", json::array({Param("metric", "string",
                                         "circularity_um, centre_offset_um, circular_deviation_um, "
                                         "straightness_min_zone_um, flatness_min_zone_um, "
                                         "strut_offset_max_um, … ")})},
       {"responses",
        {{"200", JsonResponse("{machine_id, metric, label, unit, kind, points[{measured_at, "
                              "value, measurement_id (job_id for kind calibration), test_id, "
                              "direction}]}")}}}}};
}

}  // namespace km::api::endpoints
