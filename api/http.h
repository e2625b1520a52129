// The API's own HTTP types: a request, a response, a route and the router that dispatches on
// them. Boost.Beast stays behind api/http_server.cpp and api/http_session.cpp; routes see only
// these types. Each route carries its method, path pattern, summary, role, handler and OpenAPI
// description, so the OpenAPI document is made from the same routes the server dispatches on.
// The API's routes come from one table (api/routes.cpp).
#pragma once

#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/access/roles.h"
#include "server/base/ids.h"

namespace km::api {

// The refusal of a route that needs a token when the request presented none.
inline constexpr const char* kBearerTokenNeeded =
    "this resource needs 'Authorization: Bearer TOKEN'";

struct Request {
  std::string method;
  std::string path;
  std::map<std::string, std::string> path_params;  // {id} → "7"
  std::multimap<std::string, std::string> query;
  std::map<std::string, std::string> headers;  // lower-case names
  std::string body;  // empty for routes with open_body (the body goes to the sink instead)
  std::string remote_addr;
  std::string id;     // request id: in the X-Request-Id header and in the log of server errors
  std::string route;  // the pattern of the route the path matched (also when access was refused)
  // The caller, set by the access hook when a valid token was presented (none / empty
  // otherwise).
  std::optional<server::TokenId> token_id;
  std::string token_name;
  std::optional<server::Role> token_role;

  std::optional<std::string> Query(const std::string& key) const;
  std::optional<std::string> Header(const std::string& lower_name) const;
  // The id in the path parameter `name`, as the id type of its table (server/base/ids.h);
  // throws InvalidInput on a bad id.
  template <class IdType>
  IdType PathId(const std::string& name) const {
    return IdType(PathInteger(name));
  }
  std::int64_t PathInteger(const std::string& name) const;  // a positive integer, else as above
  // The caller's token on a route that needs one; km::Unauthorized when none was presented.
  server::TokenId CallerToken() const;
  // The caller's role name ("viewer" … "admin"); "" when no token was presented.
  std::string RoleName() const;
};

struct Response {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::map<std::string, std::string> headers;

  static Response Json(const nlohmann::json& j, int status = 200);
  // A JSON text serialised before (valid UTF-8).
  static Response JsonText(std::string body, int status = 200);
};

// A body consumed piece by piece as it arrives (routes with open_body, e.g. sensor frames of
// any length). The HTTP layer reads the next piece only after Feed has returned, so no thread
// waits for the network while a client is slow.
class BodySink {
 public:
  virtual ~BodySink() = default;
  virtual void Feed(std::string_view piece) = 0;  // throws to refuse the rest of the body
  // complete = false: the connection failed or timed out before the body ended (what was fed
  // is kept; the answer cannot be sent).
  virtual Response Finish(bool complete) = 0;
};
using BodySinkFactory = std::function<std::unique_ptr<BodySink>(const Request&)>;

struct Route {
  std::string method;   // GET, POST
  std::string pattern;  // "/api/v1/measurements/{id}"
  std::string summary;
  bool needs_token = true;
  std::function<Response(const Request&)> handler;
  nlohmann::json openapi = nullptr;  // operation object extras: parameters, requestBody, responses
  // Set for routes whose body is streamed (unbounded): opened after access was granted; the
  // handler then serves only callers that pass the whole body in Request::body.
  BodySinkFactory open_body = nullptr;
  // Largest body of this route (0: the server's max_payload_bytes); a larger one is answered
  // 413 without being read. Never above the server's limit.
  std::size_t max_body_bytes = 0;
  // The least role a token needs (server/access/roles.h); the route table (api/routes.cpp) sets
  // it for every route of the API. Unset: RequiredRole's default.
  std::optional<server::Role> role = std::nullopt;
};

// The role a route needs: its own, else kPublic without needs_token, else viewer for a read
// (GET) and admin for anything else, so that nothing is silently open (api/access.cpp).
server::Role RequiredRole(const Route& route);

// Called before every route's handler (access control sits here); throws to refuse.
// It may note the caller in the request (Request::token_id, token_name, token_role).
using RequestHook = std::function<void(Request&, const Route&)>;
// Told of every answer given to a request on a worker (route: nullptr when none was found or
// access was refused), e.g. to keep an audit log; must not throw.
using ResponseHook = std::function<void(const Request&, const Route*, const Response&)>;

class Router {
 public:
  void Add(Route r) { routes_.push_back(std::move(r)); }
  void SetHook(RequestHook hook) { hook_ = std::move(hook); }
  void SetObserver(ResponseHook observer) { observer_ = std::move(observer); }
  // Gives the route (method, pattern) its own role, e.g. a route a deployment makes public.
  void SetRole(const std::string& method, const std::string& pattern, server::Role role);
  // Tells the observer of an answer (never throws).
  void Observe(const Request& req, const Route* route, const Response& res) const;
  const std::vector<Route>& routes() const { return routes_; }
  // Finds the route of the request (filling path_params) and checks access from the headers
  // alone, before any body is read. Returns the route, or sets `refusal` (401, 403, 404, 405,
  // 400) and returns nullptr. Never throws.
  const Route* Admit(Request& req, Response& refusal) const;
  // Runs a route's handler; every exception becomes a problem+json answer. Never throws.
  Response Run(const Route& route, const Request& req) const;
  // Admit, then Run.
  Response Dispatch(Request& req) const;
  // Checks access again for a request under way (a streamed body of any length): the hook as in
  // Admit; throws what it throws (Unauthorized once the token was revoked or has expired).
  void Recheck(Request& req, const Route& route) const {
    if (hook_) hook_(req, route);
  }

 private:
  std::vector<Route> routes_;
  RequestHook hook_;
  ResponseHook observer_;
};

// RFC 7807 problem document.
Response Problem(int status, const std::string& title, const std::string& detail,
                 const nlohmann::json& extra = nlohmann::json::object());

// The answer to an exception escaping a handler: 400 / 404 / 413 / 422 / 401 with the
// exception's message; 503 with Retry-After for a full queue (Unavailable) or a busy database
// (server::StorageError with busy(), logged with the request id); anything unexpected is logged
// on stderr with the request id and answered 500 naming only that id, never its message.
Response ErrorResponse(std::exception_ptr error, const Request& req);

// OpenAPI 3 document made from the route table.
nlohmann::json OpenApiDocument(const Router& router, const std::string& version);

}  // namespace km::api
