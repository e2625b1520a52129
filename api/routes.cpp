#include "api/routes.h"

#include <limits>

#include "analysis/core/errors.h"
#include "api/http_target.h"
#include "api/metrics.h"
#include "api/route_util.h"
#include "server/audits/fleet_service.h"
#include "server/base/conflict.h"
#include "server/base/request_json.h"
#include "server/base/time_util.h"

namespace km::api {
namespace {

// The X-Filename of an upload: shown in messages and lists, so it must be printable text.
std::string UploadFilename(const Request& req) {
  const auto name = req.Header("x-filename");
  if (!name || name->empty()) return "upload";
  const auto refuse = [](const std::string& why) {
    throw InvalidInput("", 0, "X-Filename", "the X-Filename header " + why);
  };
  if (name->size() > 255) refuse("is longer than 255 bytes");
  if (!IsUtf8(*name)) refuse("is not valid UTF-8");
  for (const char c : *name) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7F) refuse("holds a control character");
  }
  return *name;
}

// The answer to storing a machine definition.
json StoredJson(const server::MachineModelStored& m) {
  return json{{"machine_id", m.machine_id},
              {"version", m.version},
              {"created_at", m.created_at},
              {"created", m.created}};
}

// The order of a measurement list (?order=oldest|newest|uploaded).
server::MeasurementFilter::Order MeasurementOrder(const Request& req) {
  using Order = server::MeasurementFilter::Order;
  const auto order = req.Query("order");
  if (!order || *order == "oldest") return Order::kOldest;
  if (*order == "newest") return Order::kNewest;
  if (*order == "uploaded") return Order::kUploaded;
  throw InvalidInput("", 0, "order", "'" + *order + "' is none of oldest, newest, uploaded");
}

// Uploads and the stored measurements: list, one with its samples, results.
void AddMeasurementRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;

  router.Add(Route{
      "POST",
      "/api/v1/measurements",
      "Upload a measurement file (any kind of docs/formats.md §1)",
      true,
      [svc](const Request& req) {
        const std::string name = UploadFilename(req);
        const auto out = svc->measurements().Upload(req.body, name);
        return Response::Json(
            {{"id", out.id}, {"sha256", out.sha256}, {"kind", out.kind}, {"created", out.created}},
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
        {{"201", JsonResponse("stored: {id, sha256, kind, created: true}")},
         {"200", JsonResponse("the same bytes were stored before: the existing id")}}}}});

  router.Add(Route{
      "GET",
      "/api/v1/measurements",
      "List measurements (filter by machine, kind, time range)",
      true,
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
       {"responses", {{"200", JsonResponse("{items[], total, limit, offset}")}}}}});

  router.Add(Route{
      "GET",
      "/api/v1/measurements/{id}",
      "One measurement: metadata and samples",
      true,
      [svc](const Request& req) {
        return Response::Json(svc->measurements().MeasurementWithSamples(req.PathId("id")));
      },
      {{"responses", {{"200", JsonResponse("metadata and samples (one array per column)")}}}}});

  router.Add(
      Route{"GET",
            "/api/v1/measurements/{id}/results",
            "Analysis results (the same object the CLI prints for the file)",
            true,
            [svc](const Request& req) {
              return Response::Json(svc->measurements().Results(req.PathId("id")));
            },
            {{"responses", {{"200", JsonResponse("results of the newest analysis version")}}}}});
}

// DBB queries recomputed from a stored test: trace, CW/CCW pair, polar plot.
void AddDbbRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;

  router.Add(Route{
      "GET",
      "/api/v1/measurements/{id}/trace",
      "DBB trace of the evaluated turn for plotting (deviation about the least-squares circle)",
      true,
      [svc](const Request& req) {
        return Response::Json(svc->measurements().DbbTrace(req.PathId("id")));
      },
      {{"responses", {{"200", JsonResponse("{angle_deg[], radial_error_um[], ...}")}}}}});

  router.Add(Route{
      "GET",
      "/api/v1/measurements/{id}/pair",
      "DBB: CW/CCW pair analysis with the opposite-direction test of the same machine and "
      "test_id (circular hysteresis, bidirectional deviation, joint diagnosis)",
      true,
      [svc](const Request& req) {
        const auto id = req.PathId("id");
        auto j = svc->DbbPairJson(id);
        if (j.is_null()) {
          throw NotFound("measurement " + std::to_string(id) +
                         " has no stored test of the opposite direction");
        }
        return Response::Json(j);
      },
      {{"responses", {{"200", JsonResponse("{partner_id, pair{...}, joint_diagnosis[]}")}}}}});

  router.Add(
      Route{"GET",
            "/api/v1/measurements/{id}/reversal",
            "Straightness: the reversal of this profile with the other set-up of its pair",
            true,
            [svc](const Request& req) {
              const std::int64_t id = req.PathId("id");
              auto j = svc->measurements().StraightnessReversalJson(id);
              if (j.is_null()) {
                throw NotFound("measurement " + std::to_string(id) +
                               " has no stored profile of the other set-up of its reversal pair");
              }
              return Response::Json(j);
            },
            {{"responses",
              {{"200", JsonResponse("{partner_id, reversal{machine_um[], artefact_um[], ...}, "
                                    "profiles[]}")}}}}});

  router.Add(Route{
      "GET",
      "/api/v1/measurements/{id}/compensation",
      "Laser positioning: the compensation table a controller loads (LinuxCNC, SINUMERIK, CSV)",
      true,
      [svc](const Request& req) {
        const std::string format = req.Query("format").value_or("csv");
        Response r;
        r.content_type = format == "csv" ? "text/csv" : "text/plain; charset=utf-8";
        r.body = svc->measurements().PositioningCompensation(req.PathId("id"), format);
        return r;
      },
      {{"parameters",
        json::array({Param("format", "string",
                           "linuxcnc (nominal forward-trim reverse-trim per target), sinumerik "
                           "($AA_ENC_COMP part program), csv (default); docs/formats.md §3.15")})},
       {"responses", {{"200", {{"description", "the table as text"}}}}}}});

  router.Add(
      Route{"GET",
            "/api/v1/measurements/{id}/plot.png",
            "DBB: polar plot (both directions when the partner test is stored)",
            true,
            [svc](const Request& req) {
              render::PolarPlotOptions o;
              o.um_per_div = static_cast<double>(QueryInt(req, "um_per_div", 0, 0, 10000));
              o.divisions = static_cast<int>(QueryInt(req, "divisions", 0, 0, 50));
              if ((o.um_per_div > 0.0) != (o.divisions > 0)) {
                throw InvalidInput("", 0, o.divisions > 0 ? "um_per_div" : "divisions",
                                   "a fixed scale needs both um_per_div and divisions");
              }
              Response r;
              r.content_type = "image/png";
              r.body = svc->measurements().DbbPlotPng(req.PathId("id"), o);
              return r;
            },
            {{"parameters",
              json::array({Param("um_per_div", "integer",
                                 "fixed scale: micrometres per division (with divisions)"),
                           Param("divisions", "integer",
                                 "fixed scale: divisions of the band (with um_per_div); plots "
                                 "with the same pair share one magnification")})},
             {"responses",
              {{"200",
                {{"description", "PNG image"},
                 {"content",
                  {{"image/png", {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}}}}}}});
}

// 202 for a study queued as a background job: its id and where to follow it (also Location).
Response JobAccepted(std::int64_t id) {
  const std::string url = "/api/v1/jobs/" + std::to_string(id);
  Response r = Response::Json({{"job_id", id}, {"status_url", url}}, 202);
  r.headers["Location"] = url;
  return r;
}

// Calibration studies as background jobs, the jobs, and the machines known.
void AddJobRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;

  router.Add(WithBodyLimit(
      Route{
          "POST",
          "/api/v1/calibrations",
          "Hexapod calibration study (machine definition or stored model + DBB measurement ids + "
          "mode) as a background job",
          true,
          [svc](const Request& req) {
            const auto id = svc->studies().SubmitCalibration(JsonBody(req), req.token_id);
            return JobAccepted(id);
          },
          {{"requestBody",
            JsonRequestBody(
                {{"type", "object"},
                 {"required", json::array({"measurement_ids"})},
                 {"properties",
                  {{"machine", {{"type", "object"}}},
                   {"machine_id", {{"type", "string"}}},
                   {"machine_version", {{"type", "integer"}}},
                   {"measurement_ids", {{"type", "array"}, {"items", {{"type", "integer"}}}}},
                   {"method",
                    {{"type", "string"}, {"enum", json::array({"absolute", "centre-corrected"})}}},
                   {"reduction_study_min_tests", {{"type", "integer"}}},
                   {"max_samples_per_test", {{"type", "integer"}}}}}})},
           {"responses", {{"202", JsonResponse("{job_id, status_url}")}}}}},
      server::kMaxMachineModelBytes + kStudyRequestBytes));

  router.Add(Route{
      "GET",
      "/api/v1/jobs/{id}",
      "A background job: status, progress, result",
      true,
      [svc](const Request& req) { return Response::Json(svc->studies().Job(req.PathId("id"))); },
      {{"responses",
        {{"200", JsonResponse("{id, kind, status, progress, stage, result?, error?}")}}}}});

  router.Add(Route{
      "DELETE",
      "/api/v1/jobs/{id}",
      "Cancel a queued or running job (its owner, the token that submitted it, or an admin)",
      true,
      [svc](const Request& req) {
        const server::JobCanceller by{req.token_id, req.token_name, req.token_role == "admin"};
        try {
          return Response::Json(svc->studies().CancelJob(req.PathId("id"), by));
        } catch (const server::Conflict& e) {
          return Problem(409, "Conflict", e.what());
        }
      },
      {{"responses",
        {{"200", JsonResponse("the job, status cancelled; a running job stops at its next "
                              "progress report")},
         {"403", {{"description", "the token neither submitted the job nor is an admin"}}},
         {"409", {{"description", "the job is done, failed or cancelled already"}}}}}}});

  router.Add(Route{
      "GET",
      "/api/v1/jobs",
      "Recent background jobs",
      true,
      [svc](const Request& req) {
        const auto limit = QueryInt(req, "limit", 50, 1, 1000);
        if (const auto machine = req.Query("machine_id")) {
          return Response::Json(svc->studies().JobsOfMachine(*machine, limit));
        }
        return Response::Json(svc->studies().Jobs(limit));
      },
      {{"parameters", json::array({Param("limit", "integer", "at most this many (default 50)"),
                                   Param("machine_id", "string",
                                         "only the jobs of this machine (named in the request, "
                                         "or the machine of its DBB tests)")})},
       {"responses",
        {{"200", JsonResponse("{items[{id, kind, status, verdict, "
                              "verdict_reasons, ...}]} newest first")}}}}});

  router.Add(Route{
      "GET",
      "/api/v1/machines",
      "Machines with stored measurements or a stored machine definition",
      true,
      [svc](const Request&) {
        json items = json::array();
        const auto rules = server::AuditRuleCounts(*svc);
        for (const auto& m : svc->measurements().Machines()) {
          const auto r = rules.find(m.machine_id);
          items.push_back({{"machine_id", m.machine_id},
                           {"measurement_count", m.measurement_count},
                           {"last_timestamp", m.last_time ? json(*m.last_time) : json(nullptr)},
                           {"model_versions", m.model_versions},
                           {"audit_rules", r == rules.end() ? 0 : r->second}});
        }
        return Response::Json({{"machines", items}});
      },
      {{"responses",
        {{"200", JsonResponse("{machines[{machine_id, measurement_count, last_timestamp, "
                              "model_versions, audit_rules}]}")}}}}});
}

// Discovery studies, and saving the machine a finished job produced.
void AddStudyRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;

  router.Add(WithBodyLimit(
      Route{"POST",
            "/api/v1/discoveries",
            "Model-gap discovery study (stored model or serial + DBB measurement ids) as a "
            "background job",
            true,
            [svc](const Request& req) {
              const auto id = svc->studies().SubmitDiscovery(JsonBody(req), req.token_id);
              return JobAccepted(id);
            },
            {{"requestBody",
              JsonRequestBody(
                  {{"type", "object"},
                   {"required", json::array({"measurement_ids"})},
                   {"properties",
                    {{"machine_id", {{"type", "string"}}},
                     {"machine_version", {{"type", "integer"}}},
                     {"measurement_ids", {{"type", "array"}, {"items", {{"type", "integer"}}}}},
                     {"max_samples_per_test", {{"type", "integer"}}}}}})},
             {"responses", {{"202", JsonResponse("{job_id, status_url}")}}}}},
      kStudyRequestBytes));

  Route save{
      "POST",
      "/api/v1/jobs/{id}/save-machine",
      "Store the machine a finished calibration or discovery job produced as the next version "
      "of its model",
      true,
      [svc](const Request& req) {
        std::string note;
        if (!req.body.empty()) {
          const json body = JsonBody(req);
          if (!body.is_object()) {
            throw InvalidInput("request", 0, "", "the body must be a JSON object (or empty)");
          }
          note = server::request::OptionalString(body, "note", "");
        }
        try {
          const auto out = svc->studies().SaveJobMachine(req.PathId("id"), note);
          return Response::Json(StoredJson(out), out.created ? 201 : 200);
        } catch (const server::Conflict& e) {
          return Problem(409, "Conflict", e.what());
        }
      },
      {{"requestBody",
        JsonRequestBody({{"type", "object"}, {"properties", {{"note", {{"type", "string"}}}}}},
                        false)},
       {"responses",
        {{"201", JsonResponse("stored: {machine_id, version, created_at, created: true}")},
         {"200", JsonResponse("the same bytes as the newest version: that version")},
         {"409", {{"description", "the job is not done, or produced no machine"}}}}}}};
  save.max_body_bytes = 64u << 10;
  router.Add(std::move(save));
}

}  // namespace

void AddRoutes(Router& router, server::Service& service) {
  const Router* rt = &router;

  router.Add(Route{"GET",
                   "/healthz",
                   "Liveness and readiness",
                   false,
                   [](const Request&) {
                     return Response::Json({{"status", "ok"}});
                   },
                   {{"responses", {{"200", JsonResponse("the server is ready")}}}}});

  router.Add(
      Route{"GET",
            "/api/v1/openapi.json",
            "This OpenAPI document",
            false,
            [rt](const Request&) { return Response::Json(OpenApiDocument(*rt, kApiVersion)); },
            {{"responses", {{"200", JsonResponse("OpenAPI 3 document")}}}}});

  AddMeasurementRoutes(router, service);
  AddDbbRoutes(router, service);
  AddJobRoutes(router, service);
  AddMachineModelRoutes(router, service);
  AddStreamRoutes(router, service);
  AddServoRoutes(router, service);
  AddFleetRoutes(router, service);
  AddAuditRoutes(router, service);
  AddReportRoutes(router, service);
  AddAccessRoutes(router, service);
  AddMetricsRoute(router, service);
}

void AddMachineModelRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;

  Route upload{"POST",
               "/api/v1/machines",
               "Store a machine definition (kinemetric-machine/1) as the next version of its model",
               true,
               [svc](const Request& req) {
                 const std::string file =
                     req.Header("x-filename") ? UploadFilename(req) : "machine";
                 const auto out = svc->models().StoreMachineModel(
                     req.body, "upload", req.Query("note").value_or(""), file);
                 return Response::Json(StoredJson(out), out.created ? 201 : 200);
               },
               {{"requestBody", JsonRequestBody({{"type", "object"}})},
                {"parameters", json::array({Param("note", "string", "stored with the version")})},
                {"responses",
                 {{"201", JsonResponse("stored: {machine_id, version, created_at, created: true}")},
                  {"200", JsonResponse("the same bytes as the newest version: that version")}}}}};
  upload.max_body_bytes = server::kMaxMachineModelBytes;
  router.Add(std::move(upload));

  router.Add(Route{
      "GET",
      "/api/v1/machines/{machine_id}/definition",
      "A stored machine definition (the newest version, or ?version=N)",
      true,
      [svc](const Request& req) {
        std::optional<std::int64_t> version;
        if (req.Query("version")) {
          version = QueryInt(req, "version", 1, 1, std::numeric_limits<std::int64_t>::max());
        }
        const auto rec = svc->models().GetMachineModel(req.path_params.at("machine_id"), version);
        Response r;
        r.body = rec.document;
        r.headers["X-Machine-Version"] = std::to_string(rec.version);
        r.headers["ETag"] = "\"" + rec.sha256 + "\"";
        return r;
      },
      {{"parameters",
        json::array({Param("version", "integer", "a stored version (default: the newest)")})},
       {"responses", {{"200", JsonResponse("the document exactly as stored")}}}}});

  router.Add(Route{
      "GET",
      "/api/v1/machines/{machine_id}/definitions",
      "Every stored version of a machine definition",
      true,
      [svc](const Request& req) {
        return Response::Json(svc->models().ListMachineModels(req.path_params.at("machine_id")));
      },
      {{"responses",
        {{"200",
          JsonResponse("{machine_id, versions[{version, created_at, source, note, sha256}]}")}}}}});

  AddStudyRoutes(router, service);
}

std::string EnsureAdminToken(server::AccessStore& storage, const std::string& bootstrap) {
  return server::EnsureAdminToken(storage, bootstrap);
}

}  // namespace km::api
