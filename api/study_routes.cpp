// Endpoints of calibration and discovery studies run as background jobs, of the jobs
// themselves (follow, cancel, list, save the machine a job produced), and of the machines and
// their stored, versioned definitions (api/endpoints.h).
#include <limits>

#include "analysis/core/errors.h"
#include "api/endpoints.h"
#include "api/route_util.h"
#include "server/audits/fleet_service.h"
#include "server/base/errors.h"
#include "server/base/request_json.h"

namespace km::api::endpoints {
namespace {

// The answer to storing a machine definition.
json StoredJson(const server::MachineModelStored& m) {
  return json{{"machine_id", m.machine_id},
              {"version", m.version},
              {"created_at", m.created_at},
              {"created", m.created}};
}

// 202 for a study queued as a background job: its id and where to follow it (also Location).
Response JobAccepted(server::JobId id) {
  const std::string url = "/api/v1/jobs/" + to_string(id);
  Response r = Response::Json({{"job_id", id}, {"status_url", url}}, 202);
  r.headers["Location"] = url;
  return r;
}

json StoredResponses() {
  return {{"201", JsonResponse("stored: {machine_id, version, created_at, created: true}")},
          {"200", JsonResponse("the same bytes as the newest version: that version")}};
}

}  // namespace

Endpoint SubmitCalibration(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Hexapod calibration study (machine definition or stored model + DBB measurement ids + "
      "mode) as a background job",
      [svc](const Request& req) {
        return JobAccepted(svc->studies().SubmitCalibration(
            server::CalibrationRequest::Parse(JsonBody(req)), req.token_id));
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
       {"responses", {{"202", JsonResponse("{job_id, status_url}")}}}},
      server::kMaxMachineModelBytes + kStudyRequestBytes};
}

Endpoint GetJob(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"A background job: status, progress, result",
          [svc](const Request& req) {
            return Response::Json(svc->studies().Job(req.PathId<server::JobId>("id")));
          },
          {{"responses",
            {{"200", JsonResponse("{id, kind, status, progress, stage, result?, error?}")}}}}};
}

Endpoint CancelJob(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Cancel a queued or running job (its owner, the token that submitted it, or an admin)",
          [svc](const Request& req) {
            const server::JobCanceller by{req.token_id, req.token_name,
                                          req.token_role == server::Role::kAdmin};
            return Response::Json(svc->studies().CancelJob(req.PathId<server::JobId>("id"), by));
          },
          {{"responses",
            {{"200", JsonResponse("the job, status cancelled; a running job stops at its next "
                                  "progress report")},
             {"403", {{"description", "the token neither submitted the job nor is an admin"}}},
             {"409", {{"description", "the job is done, failed or cancelled already"}}}}}}};
}

Endpoint ListJobs(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Recent background jobs",
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
                                  "verdict_reasons, ...}]} newest first")}}}}};
}

Endpoint ListMachines(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Machines with stored measurements or a stored machine definition",
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
                                  "model_versions, audit_rules}]}")}}}}};
}

Endpoint StoreMachineDefinition(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Store a machine definition (kinemetric-machine/1) as the next version of its model",
          [svc](const Request& req) {
            const std::string file = req.Header("x-filename") ? UploadFilename(req) : "machine";
            const auto out = svc->models().StoreMachineModel(req.body, "upload",
                                                             req.Query("note").value_or(""), file);
            return Response::Json(StoredJson(out), out.created ? 201 : 200);
          },
          {{"requestBody", JsonRequestBody({{"type", "object"}})},
           {"parameters", json::array({Param("note", "string", "stored with the version")})},
           {"responses", StoredResponses()}},
          server::kMaxMachineModelBytes};
}

Endpoint GetMachineDefinition(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"A stored machine definition (the newest version, or ?version=N)",
          [svc](const Request& req) {
            std::optional<std::int64_t> version;
            if (req.Query("version")) {
              version = QueryInt(req, "version", 1, 1, std::numeric_limits<std::int64_t>::max());
            }
            const auto rec =
                svc->models().GetMachineModel(req.path_params.at("machine_id"), version);
            Response r;
            r.body = rec.document;
            r.headers["X-Machine-Version"] = std::to_string(rec.version);
            r.headers["ETag"] = "\"" + rec.sha256 + "\"";
            return r;
          },
          {{"parameters",
            json::array({Param("version", "integer", "a stored version (default: the newest)")})},
           {"responses", {{"200", JsonResponse("the document exactly as stored")}}}}};
}

Endpoint ListMachineDefinitions(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Every stored version of a machine definition",
      [svc](const Request& req) {
        return Response::Json(svc->models().ListMachineModels(req.path_params.at("machine_id")));
      },
      {{"responses",
        {{"200",
          JsonResponse("{machine_id, versions[{version, created_at, source, note, sha256}]}")}}}}};
}

Endpoint SubmitDiscovery(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Model-gap discovery study (stored model or serial + DBB measurement ids) as a "
      "background job",
      [svc](const Request& req) {
        return JobAccepted(svc->studies().SubmitDiscovery(
            server::DiscoveryRequest::Parse(JsonBody(req)), req.token_id));
      },
      {{"requestBody", JsonRequestBody({{"type", "object"},
                                        {"required", json::array({"measurement_ids"})},
                                        {"properties",
                                         {{"machine_id", {{"type", "string"}}},
                                          {"machine_version", {{"type", "integer"}}},
                                          {"measurement_ids",
                                           {{"type", "array"}, {"items", {{"type", "integer"}}}}},
                                          {"max_samples_per_test", {{"type", "integer"}}}}}})},
       {"responses", {{"202", JsonResponse("{job_id, status_url}")}}}},
      kStudyRequestBytes};
}

Endpoint SaveJobMachine(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Store the machine a finished calibration or discovery job produced as the next version "
      "of its model",
      [svc](const Request& req) {
        std::string note;
        if (!req.body.empty()) {
          const json body = JsonBody(req);
          if (!body.is_object()) {
            throw InvalidInput("request", 0, "", "the body must be a JSON object (or empty)");
          }
          note = server::request::OptionalString(body, "note", "");
        }
        const auto out = svc->studies().SaveJobMachine(req.PathId<server::JobId>("id"), note);
        return Response::Json(StoredJson(out), out.created ? 201 : 200);
      },
      {{"requestBody",
        JsonRequestBody({{"type", "object"}, {"properties", {{"note", {{"type", "string"}}}}}},
                        false)},
       {"responses",
        [] {
          json r = StoredResponses();
          r["409"] = {{"description", "the job is not done, or produced no machine"}};
          return r;
        }()}},
      64u << 10};
}

}  // namespace km::api::endpoints
