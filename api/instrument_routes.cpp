// Endpoints of the instrument register (docs/http.md "Instruments"): a new version of an
// instrument, the newest or one version, the list of the newest versions (api/endpoints.h). The
// work is done by the service (server/instruments/instrument_service.h); each uploaded file
// naming a registered serial takes its values through the measurement routes.
#include "api/endpoints.h"
#include "api/route_util.h"

namespace km::api::endpoints {
namespace {

json InstrumentBodySchema() {
  json uncertainties = {{"type", "object"}, {"additionalProperties", false}};
  for (const auto& key : server::InstrumentUncertaintyKeys()) {
    uncertainties["properties"][key] = {{"type", "number"}, {"minimum", 0}, {"maximum", 1e6}};
  }
  return {
      {"type", "object"},
      {"required", json::array({"instrument", "kind"})},
      {"additionalProperties", false},
      {"properties",
       {{"instrument", {{"type", "string"}, {"maxLength", 256}}},
        {"kind", {{"type", "string"}, {"enum", server::InstrumentKinds()}}},
        {"uncertainties", uncertainties},
        {"calibrated", {{"type", "string"}, {"format", "date"}}},
        {"calibration_interval_days",
         {{"type", "integer"}, {"minimum", 1}, {"maximum", server::kMaxCalibrationIntervalDays}}},
        {"certificate", {{"type", "string"}, {"maxLength", 256}}}}}};
}

const char* const kInstrumentKeys =
    "{serial, version, created_at, instrument, kind, uncertainties, calibrated, "
    "calibration_interval_days, calibration_due, certificate}";

}  // namespace

Endpoint PutInstrument(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Store the next version of an instrument of the register (the same entry as the newest "
      "version: that version, nothing stored)",
      [svc](const Request& req) {
        return Response::Json(svc->instruments().Put(req.path_params.at("serial"), JsonBody(req)));
      },
      {{"requestBody", JsonRequestBody(InstrumentBodySchema())},
       {"responses", {{"200", JsonResponse(std::string(kInstrumentKeys) + " + created")}}}},
      64u << 10};
}

Endpoint GetInstrument(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"An instrument of the register, the newest version or ?version=N (404 when none)",
          [svc](const Request& req) {
            std::optional<std::int64_t> version;
            if (req.Query("version")) {
              version = QueryInt(req, "version", 0, 1, std::int64_t{1} << 40);
            }
            return Response::Json(svc->instruments().Get(req.path_params.at("serial"), version));
          },
          {{"parameters",
            json::array({Param("version", "integer", "a stored version (default: the newest)")})},
           {"responses", {{"200", JsonResponse(kInstrumentKeys)}}}}};
}

Endpoint ListInstruments(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"The instrument register: the newest version of every instrument, by serial",
          [svc](const Request&) { return Response::Json(svc->instruments().List()); },
          {{"responses", {{"200", JsonResponse("{items: [instrument], total}")}}}}};
}

}  // namespace km::api::endpoints
