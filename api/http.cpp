#include "api/http.h"

#include <charconv>
#include <exception>
#include <iostream>

#include "analysis/core/errors.h"
#include "server/base/errors.h"
#include "server/base/json_answer.h"
#include "server/storage/storage.h"

namespace km::api {
namespace {

bool MatchPattern(const std::string& pattern, const std::string& path,
                  std::map<std::string, std::string>& params) {
  std::size_t p = 0, q = 0;
  params.clear();
  while (p < pattern.size() && q < path.size()) {
    if (pattern[p] == '{') {
      const auto close = pattern.find('}', p);
      const std::string name = pattern.substr(p + 1, close - p - 1);
      const auto slash = path.find('/', q);
      const std::string value = path.substr(q, slash == std::string::npos ? path.npos : slash - q);
      if (value.empty()) return false;
      params[name] = value;
      p = close + 1;
      q = slash == std::string::npos ? path.size() : slash;
    } else {
      if (pattern[p] != path[q]) return false;
      ++p;
      ++q;
    }
  }
  return p == pattern.size() && q == path.size();
}

}  // namespace

std::optional<std::string> Request::Query(const std::string& key) const {
  const auto it = query.find(key);
  if (it == query.end()) return std::nullopt;
  return it->second;
}

std::optional<std::string> Request::Header(const std::string& lower_name) const {
  const auto it = headers.find(lower_name);
  if (it == headers.end()) return std::nullopt;
  return it->second;
}

namespace {
// What the id of a route names, from the path segment before it: "/api/v1/tokens/{id}" →
// "token"; "" when the pattern does not say.
std::string IdNoun(const std::string& pattern, const std::string& name) {
  const auto at = pattern.find("/{" + name + "}");
  if (at == std::string::npos || at == 0) return "";
  const auto start = pattern.rfind('/', at - 1);
  std::string segment = pattern.substr(start + 1, at - start - 1);
  if (segment == "discoveries") return "discovery";
  if (segment.size() > 1 && segment.back() == 's') segment.pop_back();
  return segment;
}
}  // namespace

std::int64_t Request::PathInteger(const std::string& name) const {
  const auto it = path_params.find(name);
  const std::string v = it == path_params.end() ? "" : it->second;
  std::int64_t id = 0;
  const auto [ptr, ec] = std::from_chars(v.data(), v.data() + v.size(), id);
  if (ec != std::errc() || ptr != v.data() + v.size() || id <= 0) {
    const std::string noun = IdNoun(route, name);
    const bool vowel = noun.empty() || std::string("aeiou").find(noun[0]) != std::string::npos;
    throw InvalidInput("", 0, name,
                       "'" + v + "' is not " + (vowel ? "an " : "a ") + noun +
                           (noun.empty() ? "" : " ") + "id (a positive integer)");
  }
  return id;
}

server::TokenId Request::CallerToken() const {
  if (!token_id) throw server::Unauthorized(kBearerTokenNeeded);
  return *token_id;
}

std::string Request::RoleName() const {
  return token_role ? server::RoleName(*token_role) : "";
}

Response Response::Json(const nlohmann::json& j, int status) {
  Response r;
  r.status = status;
  r.body = server::AnswerText(j);
  return r;
}

Response Response::JsonText(std::string body, int status) {
  Response r;
  r.status = status;
  r.body = std::move(body);
  return r;
}

Response Problem(int status, const std::string& title, const std::string& detail,
                 const nlohmann::json& extra) {
  nlohmann::json j = extra;
  j["type"] = "about:blank";
  j["title"] = title;
  j["status"] = status;
  j["detail"] = detail;
  Response r;
  r.status = status;
  r.content_type = "application/problem+json";
  r.body = server::AnswerText(j);
  return r;
}

const Route* Router::Admit(Request& req, Response& refusal) const {
  bool path_known = false;
  for (const auto& route : routes_) {
    std::map<std::string, std::string> params;
    if (!MatchPattern(route.pattern, req.path, params)) continue;
    path_known = true;
    if (route.method != req.method) continue;
    req.path_params = std::move(params);
    req.route = route.pattern;
    try {
      if (hook_) hook_(req, route);
    } catch (...) {
      refusal = ErrorResponse(std::current_exception(), req);
      return nullptr;
    }
    return &route;
  }
  refusal = path_known
                ? Problem(405, "Method Not Allowed", req.method + " is not allowed on " + req.path)
                : Problem(404, "Not Found", "no such resource: " + req.path);
  return nullptr;
}

void Router::SetRole(const std::string& method, const std::string& pattern, server::Role role) {
  for (auto& route : routes_) {
    if (route.method == method && route.pattern == pattern) route.role = role;
  }
}

Response Router::Run(const Route& route, const Request& req) const {
  // The HTTP server refuses such a body before reading it; callers that pass the whole body
  // (tests, tools) meet the same limit here.
  if (route.max_body_bytes > 0 && req.body.size() > route.max_body_bytes) {
    return Problem(413, "Payload Too Large",
                   "the request body exceeds " + std::to_string(route.max_body_bytes) + " bytes");
  }
  try {
    return route.handler(req);
  } catch (...) {
    return ErrorResponse(std::current_exception(), req);
  }
}

Response Router::Dispatch(Request& req) const {
  Response refusal;
  const Route* route = Admit(req, refusal);
  Response res = route ? Run(*route, req) : refusal;
  Observe(req, route, res);
  return res;
}

void Router::Observe(const Request& req, const Route* route, const Response& res) const {
  if (!observer_) return;
  try {
    observer_(req, route, res);
  } catch (const std::exception& e) {
    std::cerr << "kinemetricd: request " << req.id << ": " << e.what() << std::endl;
  } catch (...) {  // NOLINT(bugprone-empty-catch): an observer never fails a request
  }
}

namespace {
void LogFailure(const Request& req, const std::string& what) {
  std::cerr << "kinemetricd: request " << (req.id.empty() ? "(none)" : req.id) << " " << req.method
            << " " << req.path << " failed: " << what << std::endl;
}
}  // namespace

Response ErrorResponse(std::exception_ptr error, const Request& req) {
  try {
    std::rethrow_exception(error);
  } catch (const server::StorageError& e) {
    // The database's own words (paths, SQL) stay in the log; the client gets the request id.
    LogFailure(req, e.what());
    if (e.busy()) {
      Response r = Problem(503, "Service Unavailable",
                           "the database is busy; retry shortly (request id " +
                               (req.id.empty() ? std::string("(none)") : req.id) + ")",
                           {{"request_id", req.id}});
      r.headers["Retry-After"] = "1";
      return r;
    }
  } catch (const TooLarge& e) {
    return Problem(413, "Payload Too Large", e.what());
  } catch (const InvalidInput& e) {
    nlohmann::json extra = nlohmann::json::object();
    if (!e.file().empty()) extra["file"] = e.file();
    if (e.line() > 0) extra["line"] = e.line();
    if (!e.field().empty()) extra["field"] = e.field();
    extra["reason"] = e.reason();
    return Problem(400, "Invalid input", e.what(), extra);
  } catch (const NotFound& e) {
    return Problem(404, "Not Found", e.what());
  } catch (const server::Unauthorized& e) {
    Response r = Problem(401, "Unauthorized", e.what());
    r.headers["WWW-Authenticate"] = "Bearer";
    return r;
  } catch (const server::Forbidden& e) {
    return Problem(403, "Forbidden", e.what());
  } catch (const Unavailable& e) {
    Response r = Problem(503, "Service Unavailable", e.what());
    r.headers["Retry-After"] = "1";
    return r;
  } catch (const server::Conflict& e) {
    return Problem(409, "Conflict", e.what());
  } catch (const NotObservable& e) {
    return Problem(422, "Not observable", e.what());
  } catch (const DidNotConverge& e) {
    return Problem(422, "Did not converge", e.what());
  } catch (const std::exception& e) {
    LogFailure(req, e.what());
  } catch (...) {
    LogFailure(req, "an unknown error");
  }
  return Problem(500, "Internal Server Error",
                 "the request failed on the server; the server log names it by request id " +
                     (req.id.empty() ? std::string("(none)") : req.id),
                 {{"request_id", req.id}});
}

nlohmann::json OpenApiDocument(const Router& router, const std::string& version) {
  nlohmann::json doc;
  doc["openapi"] = "3.0.3";
  doc["info"] = {{"title", "kinemetric API"},
                 {"version", version},
                 {"description",
                  "Machine-tool accuracy metrology: measurements, analysis results, machines."}};
  doc["components"]["securitySchemes"]["bearer"] = {{"type", "http"}, {"scheme", "bearer"}};
  doc["components"]["schemas"]["Problem"] = {{"type", "object"},
                                             {"properties",
                                              {{"type", {{"type", "string"}}},
                                               {"title", {{"type", "string"}}},
                                               {"status", {{"type", "integer"}}},
                                               {"detail", {{"type", "string"}}},
                                               {"file", {{"type", "string"}}},
                                               {"line", {{"type", "integer"}}},
                                               {"field", {{"type", "string"}}}}}};
  doc["paths"] = nlohmann::json::object();
  for (const auto& r : router.routes()) {
    nlohmann::json op = r.openapi.is_object() ? r.openapi : nlohmann::json::object();
    op["summary"] = r.summary;
    std::string method = r.method;
    for (auto& c : method) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    op["operationId"] = method + r.pattern;
    op["x-required-role"] = server::RoleName(RequiredRole(r));
    if (r.needs_token) {
      op["security"] = nlohmann::json::array({{{"bearer", nlohmann::json::array()}}});
    } else {
      op["security"] = nlohmann::json::array();
    }
    if (!op.contains("responses")) op["responses"] = nlohmann::json::object();
    op["responses"]["default"] = {
        {"description", "error"},
        {"content",
         {{"application/problem+json", {{"schema", {{"$ref", "#/components/schemas/Problem"}}}}}}}};
    // Every {name} of the pattern is a required path parameter ({id}: a positive integer),
    // unless the route declares it itself.
    for (std::size_t open = r.pattern.find('{'); open != std::string::npos;
         open = r.pattern.find('{', open + 1)) {
      const std::string name = r.pattern.substr(open + 1, r.pattern.find('}', open) - open - 1);
      bool declared = false;
      if (op.contains("parameters")) {
        for (const auto& p : op["parameters"]) {
          declared = declared || (p.value("in", "") == "path" && p.value("name", "") == name);
        }
      }
      if (declared) continue;
      op["parameters"].push_back(
          {{"name", name},
           {"in", "path"},
           {"required", true},
           {"schema", name == "id" ? nlohmann::json{{"type", "integer"}, {"minimum", 1}}
                                   : nlohmann::json{{"type", "string"}}}});
    }
    doc["paths"][r.pattern][method] = op;
  }
  return doc;
}

}  // namespace km::api
