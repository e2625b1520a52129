// Access control of the API: the role a route needs (RequiredRole; the route table of
// api/routes.cpp gives each route its role), the token hook that checks `Authorization: Bearer`
// (401 without a valid token, 403 with a token of a lower role), and the audit hook that records
// every state-changing request.
#include <chrono>
#include <memory>
#include <mutex>
#include <unordered_map>

#include "analysis/core/errors.h"
#include "api/http_framing.h"
#include "api/route_util.h"
#include "api/routes.h"
#include "server/access/access.h"
#include "server/base/errors.h"
#include "server/base/sha256.h"

namespace km::api {
namespace {

using server::Role;

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
                          std::function<void(server::TokenId)> note_use) {
  auto cache = std::make_shared<TokenCache>();
  return [authenticate = std::move(authenticate), note_use = std::move(note_use), cache](
             Request& req, const Route& route) {
    const Role need = RequiredRole(route);
    if (need == Role::kPublic) return;
    const auto auth = req.Header("authorization");
    const auto token = auth ? BearerToken(*auth) : std::nullopt;
    if (!token) throw server::Unauthorized(kBearerTokenNeeded);
    // Looked up by the SHA-256 of the secret: no byte of a stored secret is ever compared.
    const std::string sha = server::Sha256Hex(*token);
    auto caller = cache->Find(sha);
    if (!caller) {
      caller = authenticate(sha);
      cache->Remember(sha, *caller);
      note_use(caller->token_id);
    }
    req.token_id = caller->token_id;
    req.token_name = caller->name;
    req.token_role = caller->role;
    if (caller->role < need) {
      throw server::Forbidden(req.method + " " + route.pattern + " needs a token of role '" +
                              server::RoleName(need) + "' or above; this token's role is '" +
                              server::RoleName(caller->role) + "'");
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
      if (j.contains("certificate") && j.contains("approved_by")) {  // a report approved
        parts.push_back("certificate " + j["certificate"].get<std::string>() + " revision " +
                        j["revision"].dump() + " approved");
      } else if (j.contains("findings") && j.contains("id")) {
        parts.push_back("audit " + j["id"].dump());  // an accuracy-audit run
      } else if (j.contains("job_id")) {
        parts.push_back("job " + j["job_id"].dump());
      } else if (j.contains("id") && (j.contains("kind") || j.contains("sha256")) &&
                 !j.contains("status")) {  // a job's answer (kind, status) names no measurement
        parts.push_back("measurement " + j["id"].dump());
      } else if (j.contains("id") && req.path_params.empty() && !first_noun.empty()) {
        parts.push_back(first_noun + " " + j["id"].dump());
      } else if (j.contains("tolerances") && j.contains("version")) {
        parts.push_back("tolerances version " + j["version"].dump());  // a tolerance table
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
  return route.method == "GET" ? Role::kViewer : Role::kAdmin;
}

RequestHook TokenHook(server::Service& service) {
  server::Service* svc = &service;
  return TokenHookOver(
      [svc](const std::string& sha) { return server::Authenticate(svc->storage(), sha); },
      [rec = std::make_shared<server::TokenUseRecorder>(svc->storage())](server::TokenId id) {
        rec->Note(id);
      });
}

RequestHook TokenHook(server::AccessStore& storage) {
  server::AccessStore* st = &storage;
  return TokenHookOver([st](const std::string& sha) { return server::Authenticate(*st, sha); },
                       [rec = std::make_shared<server::TokenUseRecorder>(*st)](server::TokenId id) {
                         rec->Note(id);
                       });
}

ResponseHook AuditHook(server::Service& service) {
  server::Service* svc = &service;
  return [svc](const Request& req, const Route* route, const Response& res) {
    if (req.method == "GET" || req.method == "HEAD" || req.method == "OPTIONS") return;
    if (!route && res.status != 401 && res.status != 403) return;
    server::AuditEntry e;
    e.token_id = req.token_id;
    e.token_name = req.token_name;
    e.role = req.RoleName();
    e.method = req.method;
    e.path = req.path;
    e.status = res.status;
    e.subject = AuditSubject(route, req, res);
    svc->access().RecordAudit(e);
  };
}

}  // namespace km::api
