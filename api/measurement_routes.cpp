// Endpoints of uploads and stored measurements (list, one with its samples, results), and of the
// views recomputed from a stored measurement: the DBB trace, CW/CCW pair and polar plot, the
// straightness reversal, the positioning compensation table (api/endpoints.h).
#include <charconv>
#include <cmath>
#include <system_error>

#include "analysis/core/errors.h"
#include "api/endpoints.h"
#include "api/route_util.h"

namespace km::api::endpoints {
namespace {

// The order of a measurement list (?order=oldest|newest|uploaded).
server::MeasurementFilter::Order MeasurementOrder(const Request& req) {
  using Order = server::MeasurementFilter::Order;
  const auto order = req.Query("order");
  if (!order || *order == "oldest") return Order::kOldest;
  if (*order == "newest") return Order::kNewest;
  if (*order == "uploaded") return Order::kUploaded;
  throw InvalidInput("", 0, "order", "'" + *order + "' is none of oldest, newest, uploaded");
}

// A decimal query value in [0, most] (0 when absent): "0.5", "2"; anything else is refused
// naming the parameter.
double QueryMicrometres(const Request& req, const std::string& key, double most) {
  const auto v = req.Query(key);
  if (!v) return 0.0;
  double out = 0.0;
  const char* end = v->data() + v->size();
  const auto [ptr, ec] = std::from_chars(v->data(), end, out);
  if (ec != std::errc() || ptr != end || !std::isfinite(out) || out < 0.0 || out > most) {
    throw InvalidInput(
        "", 0, key,
        "'" + *v + "' is not a number from 0 to " + std::to_string(static_cast<int>(most)));
  }
  return out;
}

// The name a browser saves a compensation table under: kinemetric-<id>-compensation with the
// extension of its format (LinuxCNC's .comp file of COMP_FILE_TYPE, SINUMERIK's .spf
// subprogram, .csv); letters, digits, '.', '-' and '_' only. Called after the format was accepted.
std::string CompensationFileName(server::MeasurementId id, const std::string& format) {
  const char* ext = format == "linuxcnc" ? ".comp" : format == "sinumerik" ? ".spf" : ".csv";
  return "kinemetric-" + to_string(id) + "-compensation" + ext;
}

}  // namespace

Endpoint UploadMeasurement(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Upload a measurement file (any kind of docs/formats.md §1)",
      [svc](const Request& req) {
        const std::string name = UploadFilename(req);
        const auto out = svc->measurements().Upload(req.body, name);
        return Response::Json({{"id", out.id},
                               {"sha256", out.sha256},
                               {"kind", out.kind},
                               {"created", out.created},
                               {"conformance", out.conformance}},
                              out.created ? 201 : 200);
      },
      {{"requestBody",
        {{"required", true}, {"content", {{"text/plain", {{"schema", {{"type", "string"}}}}}}}}},
       {"parameters", json::array({{{"name", "X-Filename"},
                                    {"in", "header"},
                                    {"required", false},
                                    {"description",
                                     "file name used in validation messages: UTF-8 without "
                                     "control characters, at most 255 bytes"},
                                    {"schema", {{"type", "string"}}}}})},
       {"responses",
        {{"201", JsonResponse("stored: {id, sha256, kind, created: true, conformance}")},
         {"200", JsonResponse("the same bytes were stored before: the existing id")}}}}};
}

Endpoint ListMeasurements(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "List measurements (filter by machine, kind, time range)",
      [svc](const Request& req) {
        server::MeasurementFilter f;
        f.machine_id = req.Query("machine_id");
        f.kind = req.Query("kind");
        f.test_id = req.Query("test_id");
        f.from = QueryTime(req, "from");
        f.to = QueryTime(req, "to");
        f.text = req.Query("q");
        f.order = MeasurementOrder(req);
        f.limit = QueryInt(req, "limit", 50, 1, 1000);
        f.offset = QueryInt(req, "offset", 0, 0, std::int64_t{1} << 40);
        json page = svc->measurements().ListMeasurements(f);
        page["limit"] = f.limit;
        page["offset"] = f.offset;
        return Response::Json(page);
      },
      {{"parameters",
        json::array({Param("machine_id", "string", "only this machine"),
                     Param("kind", "string", "dbb, tracker, straightness, flatness, parallelism"),
                     Param("test_id", "string", "only this test"),
                     Param("from", "string", "ISO 8601, inclusive (measurement time)"),
                     Param("to", "string", "ISO 8601, exclusive"),
                     Param("q", "string",
                           "free text: part of the file name, test_id, direction or kind, "
                           "or a measurement id (258 or #258)"),
                     Param("order", "string",
                           "oldest (default: measurement time, ascending), newest (measurement "
                           "time, descending), uploaded (newest upload first)"),
                     Param("limit", "integer", "page size, 1 to 1000 (default 50)"),
                     Param("offset", "integer", "items to skip")})},
       {"responses",
        {{"200", JsonResponse("{items[{…, key_result, conformance}], total, limit, offset}")}}}}};
}

Endpoint GetMeasurement(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"One measurement: metadata and samples",
          [svc](const Request& req) {
            return Response::Json(svc->measurements().MeasurementWithSamples(
                req.PathId<server::MeasurementId>("id")));
          },
          {{"responses",
            {{"200", JsonResponse("metadata, samples (one array per column), conformance")}}}}};
}

Endpoint MeasurementResults(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Analysis results (the same object the CLI prints for the file)",
          [svc](const Request& req) {
            return Response::JsonText(
                *svc->measurements().ResultsAnswer(req.PathId<server::MeasurementId>("id")));
          },
          {{"responses",
            {{"200", JsonResponse("results of the newest analysis version, with conformance")}}}}};
}

Endpoint DbbTrace(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"DBB trace of the evaluated turn for plotting (deviation about the least-squares circle)",
          [svc](const Request& req) {
            return Response::Json(
                svc->measurements().DbbTrace(req.PathId<server::MeasurementId>("id")));
          },
          {{"responses", {{"200", JsonResponse("{angle_deg[], radial_error_um[], ...}")}}}}};
}

Endpoint DbbPair(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "DBB: CW/CCW pair analysis with the opposite-direction test of the same machine and "
      "test_id (circular hysteresis, bidirectional deviation, joint diagnosis)",
      [svc](const Request& req) {
        const auto id = req.PathId<server::MeasurementId>("id");
        auto j = svc->DbbPairJson(id);
        if (j.is_null()) {
          throw NotFound("measurement " + to_string(id) +
                         " has no stored test of the opposite direction");
        }
        return Response::Json(j);
      },
      {{"responses", {{"200", JsonResponse("{partner_id, pair{...}, joint_diagnosis[]}")}}}}};
}

Endpoint StraightnessReversal(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Straightness: the reversal of this profile with the other set-up of its pair",
          [svc](const Request& req) {
            const auto id = req.PathId<server::MeasurementId>("id");
            auto j = svc->measurements().StraightnessReversalJson(id);
            if (j.is_null()) {
              throw NotFound("measurement " + to_string(id) +
                             " has no stored profile of the other set-up of its reversal pair");
            }
            return Response::Json(j);
          },
          {{"responses",
            {{"200", JsonResponse("{partner_id, reversal{machine_um[], artefact_um[], ...}, "
                                  "profiles[]}")}}}}};
}

Endpoint PositioningCompensation(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Laser positioning: the compensation table a controller loads (LinuxCNC, SINUMERIK, CSV)",
          [svc](const Request& req) {
            const std::string format = req.Query("format").value_or("csv");
            const auto id = req.PathId<server::MeasurementId>("id");
            Response r;
            r.content_type = format == "csv" ? "text/csv" : "text/plain; charset=utf-8";
            r.body = svc->measurements().PositioningCompensation(id, format);
            r.headers["Content-Disposition"] =
                "attachment; filename=\"" + CompensationFileName(id, format) + "\"";
            return r;
          },
          {{"parameters",
            json::array({Param("format", "string",
                               "linuxcnc (nominal forward-trim reverse-trim per target), sinumerik "
                               "($AA_ENC_COMP part program), csv (default); docs/formats.md "
                               "§3.15")})},
           {"responses",
            {{"200",
              {{"description",
                "the table as text, Content-Disposition: attachment; filename=\"kinemetric-{id}-"
                "compensation.comp|.spf|.csv\""}}}}}}};
}

Endpoint DbbPlotPng(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"DBB: polar plot (both directions when the partner test is stored)",
          [svc](const Request& req) {
            render::PolarPlotOptions o;
            o.um_per_div = QueryMicrometres(req, "um_per_div", 10000.0);
            o.divisions = static_cast<int>(QueryInt(req, "divisions", 0, 0, 50));
            if ((o.um_per_div > 0.0) != (o.divisions > 0)) {
              throw InvalidInput("", 0, o.divisions > 0 ? "um_per_div" : "divisions",
                                 "a fixed scale needs both um_per_div and divisions");
            }
            Response r;
            r.content_type = "image/png";
            r.body = svc->measurements().DbbPlotPng(req.PathId<server::MeasurementId>("id"), o);
            return r;
          },
          {{"parameters",
            json::array({Param("um_per_div", "number",
                               "fixed scale: micrometres per division, a decimal such as 0.5 (with "
                               "divisions)"),
                         Param("divisions", "integer",
                               "fixed scale: divisions of the band (with um_per_div); plots "
                               "with the same pair share one magnification")})},
           {"responses",
            {{"200",
              {{"description", "PNG image"},
               {"content",
                {{"image/png", {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}}}}}}};
}

}  // namespace km::api::endpoints
