// Access control of the API: the role each route needs (RequiredRole), the token hook that
// checks `Authorization: Bearer` (401 without a valid token, 403 with a token of a lower role),
// the audit hook that records every state-changing request, and the routes of tokens and the
// audit log (admin).
#include <chrono>
#include <memory>
#include <mutex>
#include <unordered_map>

#include "analysis/core/errors.h"
#include "api/route_util.h"
#include "api/routes.h"
#include "server/access/access.h"
#include "server/base/conflict.h"
#include "server/base/sha256.h"

namespace km::api {
namespace {

using server::Role;

struct PolicyEntry {
  const char* method;
  const char* pattern;
  Role role;
};

// Every route that is neither a read (GET: viewer) nor declares its own role. A route missing
// here needs admin: nothing is silently open (tests/unit/api/access_test.cpp lists every route).
constexpr PolicyEntry kPolicy[] = {
    {"POST", "/api/v1/measurements", Role::kOperator},
    {"POST", "/api/v1/streams", Role::kOperator},
    {"POST", "/api/v1/streams/{id}/frames", Role::kOperator},
    {"POST", "/api/v1/streams/{id}/profile", Role::kOperator},
    {"POST", "/api/v1/streams/{id}/servo", Role::kOperator},
    {"POST", "/api/v1/servo/joints", Role::kOperator},
    {"POST", "/api/v1/calibrations", Role::kEngineer},
    {"POST", "/api/v1/discoveries", Role::kEngineer},
    {"POST", "/api/v1/jobs/{id}/save-machine", Role::kEngineer},
    // Beyond the role, only the job's owner or an admin (StudyService::CancelJob).
    {"DELETE", "/api/v1/jobs/{id}", Role::kEngineer},
    {"POST", "/api/v1/machines", Role::kEngineer},
    {"POST", "/api/v1/servo/identify", Role::kEngineer},
    {"PUT", "/api/v1/machines/{machine_id}/audit", Role::kEngineer},
    {"POST", "/api/v1/machines/{machine_id}/audit/run", Role::kEngineer},
    // Devices poll hosts on the network: admin only, reading their status too.
    {"GET", "/api/v1/devices", Role::kAdmin},
    {"POST", "/api/v1/devices", Role::kAdmin},
    {"DELETE", "/api/v1/devices/{name}", Role::kAdmin},
};

// Recently accepted tokens, so that a busy client costs no database read per request. An entry
// is trusted for kTrust at most and never past its token's expiry; a revocation in this process
// empties the cache at once (server::TokenRevocations).
class TokenCache {
 public:
  std::optional<server::Caller> Find(const std::string& sha) {
    std::lock_guard lock(mu_);
    const auto generation = server::TokenRevocations();
    if (generation != generation_) {
      known_.clear();
      generation_ = generation;
    }
    const auto it = known_.find(sha);
    if (it == known_.end()) return std::nullopt;
    const auto& [caller, since] = it->second;
    const auto now = std::chrono::system_clock::now();
    const auto unix_now =
        std::chrono::duration_cast<std::chrono::seconds>(now.time_since_epoch()).count();
    if (now - since >= kTrust || (caller.expires_unix && unix_now >= *caller.expires_unix)) {
      known_.erase(it);
      return std::nullopt;
    }
    return caller;
  }
  void Remember(const std::string& sha, const server::Caller& caller) {
    std::lock_guard lock(mu_);
    if (server::TokenRevocations() != generation_) return;  // Find clears first
    if (known_.size() >= kMaxEntries) known_.clear();
    known_[sha] = {caller, std::chrono::system_clock::now()};
  }

 private:
  static constexpr auto kTrust = std::chrono::seconds(2);
  static constexpr std::size_t kMaxEntries = 1024;
  std::mutex mu_;
  std::uint64_t generation_ = 0;
  std::unordered_map<std::string, std::pair<server::Caller, std::chrono::system_clock::time_point>>
      known_;
};

// The hook over an authentication of token hashes (throws Unauthorized); each authentication
// (a token not in the cache) is noted as a use of the token (server::TokenUseRecorder).
RequestHook TokenHookOver(std::function<server::Caller(const std::string&)> authenticate,
                          std::function<void(std::int64_t)> note_use) {
  auto cache = std::make_shared<TokenCache>();
  return [authenticate = std::move(authenticate), note_use = std::move(note_use), cache](
             Request& req, const Route& route) {
    const Role need = RequiredRole(route);
    if (need == Role::kPublic) return;
    const auto auth = req.Header("authorization");
    if (!auth || auth->rfind("Bearer ", 0) != 0 || auth->size() <= 7) {
      throw Unauthorized("this resource needs 'Authorization: Bearer TOKEN'");
    }
    // Looked up by the SHA-256 of the secret: no byte of a stored secret is ever compared.
    const std::string sha = server::Sha256Hex(auth->substr(7));
    auto caller = cache->Find(sha);
    if (!caller) {
      caller = authenticate(sha);
      cache->Remember(sha, *caller);
      note_use(caller->token_id);
    }
    req.token_id = caller->token_id;
    req.token_name = caller->name;
    req.token_role = server::RoleName(caller->role);
    if (caller->role < need) {
      throw Forbidden(req.method + " " + route.pattern + " needs a token of role '" +
                      server::RoleName(need) + "' or above; this token's role is '" +
                      req.token_role + "'");
    }
  };
}

// The noun of a path segment: "measurements" → "measurement".
std::string Noun(const std::string& segment) {
  if (segment == "discoveries") return "discovery";
  if (segment.size() > 1 && segment.back() == 's') return segment.substr(0, segment.size() - 1);
  return segment;
}

// What a request acted on: the resource of its path ("measurement 7", "token 3", "device d1",
// "machine m1") and what the answer created ("job 12", "measurement 9", "stream 4").
std::string AuditSubject(const Route* route, const Request& req, const Response& res) {
  std::vector<std::string> parts;
  std::string first_noun;
  if (route) {
    const std::string& p = route->pattern;
    std::size_t start = p.rfind("/api/v1/", 0) == 0 ? 8 : 1;
    const auto slash = p.find('/', start);
    first_noun = Noun(p.substr(start, slash == std::string::npos ? p.npos : slash - start));
    for (const auto& [name, value] : req.path_params) {
      const auto at = p.find("{" + name + "}");
      const auto prev = at == std::string::npos ? std::string::npos : p.rfind('/', at - 2);
      if (prev == std::string::npos) continue;
      parts.push_back(Noun(p.substr(prev + 1, at - 2 - prev)) + " " + value);
    }
  }
  if (res.status >= 200 && res.status < 300 && res.content_type == "application/json") {
    const auto j = json::parse(res.body, nullptr, false);
    if (j.is_object()) {
      if (j.contains("findings") && j.contains("id")) {
        parts.push_back("audit " + j["id"].dump());  // an accuracy-audit run
      } else if (j.contains("job_id")) {
        parts.push_back("job " + j["job_id"].dump());
      } else if (j.contains("id") && (j.contains("kind") || j.contains("sha256")) &&
                 !j.contains("status")) {  // a job's answer (kind, status) names no measurement
        parts.push_back("measurement " + j["id"].dump());
      } else if (j.contains("id") && req.path_params.empty() && !first_noun.empty()) {
        parts.push_back(first_noun + " " + j["id"].dump());
      } else if (j.contains("machine_id") && j.contains("version")) {
        parts.push_back("machine " + j["machine_id"].get<std::string>() + " version " +
                        j["version"].dump());
      }
    }
  }
  std::string out;
  for (const auto& part : parts) out += (out.empty() ? "" : ", ") + part;
  return out;
}

}  // namespace

Role RequiredRole(const Route& route) {
  if (route.role) return *route.role;
  if (!route.needs_token) return Role::kPublic;
  for (const auto& e : kPolicy) {
    if (route.method == e.method && route.pattern == e.pattern) return e.role;
  }
  return route.method == "GET" ? Role::kViewer : Role::kAdmin;
}

RequestHook TokenHook(server::Service& service) {
  server::Service* svc = &service;
  return TokenHookOver(
      [svc](const std::string& sha) { return server::Authenticate(svc->storage(), sha); },
      [rec = std::make_shared<server::TokenUseRecorder>(svc->storage())](std::int64_t id) {
        rec->Note(id);
      });
}

RequestHook TokenHook(server::AccessStore& storage) {
  server::AccessStore* st = &storage;
  return TokenHookOver(
      [st](const std::string& sha) { return server::Authenticate(*st, sha); },
      [rec = std::make_shared<server::TokenUseRecorder>(*st)](std::int64_t id) { rec->Note(id); });
}

ResponseHook AuditHook(server::Service& service) {
  server::Service* svc = &service;
  return [svc](const Request& req, const Route* route, const Response& res) {
    if (req.method == "GET" || req.method == "HEAD" || req.method == "OPTIONS") return;
    if (!route && res.status != 401 && res.status != 403) return;
    server::AuditEntry e;
    e.token_id = req.token_id;
    e.token_name = req.token_name;
    e.role = req.token_role;
    e.method = req.method;
    e.path = req.path;
    e.status = res.status;
    e.subject = AuditSubject(route, req, res);
    svc->access().RecordAudit(e);
  };
}

void AddAccessRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;
  router.Add(
      Route{"GET",
            "/api/v1/whoami",
            "The caller: its token's id, name and role (e.g. for a dashboard to hide what the role "
            "may not do)",
            true,
            [](const Request& req) {
              return Response::Json(
                  {{"token_id", req.token_id}, {"name", req.token_name}, {"role", req.token_role}});
            },
            {{"responses", {{"200", JsonResponse("{token_id, name, role}")}}}}});
  Route create{
      "POST",
      "/api/v1/tokens",
      "Create an access token (the secret is shown only in this answer)",
      true,
      [svc](const Request& req) {
        Response r = Response::Json(svc->access().CreateToken(JsonBody(req)), 201);
        r.headers["Cache-Control"] = "no-store";
        return r;
      },
      {{"requestBody",
        JsonRequestBody({{"type", "object"},
                         {"required", json::array({"name", "role"})},
                         {"properties",
                          {{"name", {{"type", "string"}}},
                           {"role",
                            {{"type", "string"},
                             {"enum", json::array({"viewer", "operator", "engineer", "admin"})}}},
                           {"expires_in_s", {{"type", "integer"}, {"minimum", 1}}}}}})},
       {"responses", {{"201", JsonResponse("{id, token, name, role, expires_at}")}}}}};
  create.max_body_bytes = 4096;
  create.role = Role::kAdmin;
  router.Add(std::move(create));

  Route list{"GET",
             "/api/v1/tokens",
             "Access tokens (never their secrets)",
             true,
             [svc](const Request&) { return Response::Json(svc->access().ListTokens()); },
             {{"responses",
               {{"200", JsonResponse("{items[{id, name, role, created_at, expires_at, "
                                     "revoked_at, state}]}")}}}}};
  list.role = Role::kAdmin;
  router.Add(std::move(list));

  Route revoke{"DELETE",
               "/api/v1/tokens/{id}",
               "Revoke an access token at once",
               true,
               [svc](const Request& req) {
                 try {
                   return Response::Json(svc->access().RevokeToken(req.PathId("id")));
                 } catch (const server::Conflict& e) {
                   return Problem(409, "Conflict", e.what());
                 }
               },
               {{"responses",
                 {{"200", JsonResponse("{id, revoked_at}")},
                  {"409", {{"description", "the last active admin token"}}}}}}};
  revoke.role = Role::kAdmin;
  router.Add(std::move(revoke));

  Route audit{"GET",
              "/api/v1/audit-log",
              "Audit log of state-changing requests (who, what, when), newest first",
              true,
              [svc](const Request& req) {
                return Response::Json(
                    svc->access().AuditLog(QueryInt(req, "limit", 100, 1, 1000),
                                           QueryInt(req, "offset", 0, 0, std::int64_t{1} << 40)));
              },
              {{"parameters", json::array({Param("limit", "integer", "1 to 1000 (default 100)"),
                                           Param("offset", "integer", "entries to skip")})},
               {"responses",
                {{"200", JsonResponse("{items[{id, at, token_id, token_name, role, method, path, "
                                      "status, subject}], total, limit, offset}")}}}}};
  audit.role = Role::kAdmin;
  router.Add(std::move(audit));
}

}  // namespace km::api
