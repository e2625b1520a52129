// The API's own HTTP types and route table. cpp-httplib stays behind http_server.cpp; routes
// see only these types. One table lists every route (method, path pattern, summary, whether a
// token is needed, handler, OpenAPI description), so the OpenAPI document is made from the same
// table the server dispatches on.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace km::api {

struct Request {
  std::string method;
  std::string path;
  std::map<std::string, std::string> path_params;  // {id} → "7"
  std::multimap<std::string, std::string> query;
  std::map<std::string, std::string> headers;  // lower-case names
  std::string body;  // empty for routes with streams_body (read with read_body instead)
  std::string remote_addr;
  // Routes with streams_body: reads the body as it arrives, calling the sink with each piece
  // until the body ends or the sink returns false. Returns false when the connection failed
  // before the body was complete.
  std::function<bool(const std::function<bool(std::string_view)>&)> read_body;

  std::optional<std::string> Query(const std::string& key) const;
  std::optional<std::string> Header(const std::string& lower_name) const;
  std::int64_t PathId(const std::string& name) const;  // throws InvalidInput on a bad id
};

struct Response {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::map<std::string, std::string> headers;

  static Response Json(const nlohmann::json& j, int status = 200);
};

struct Route {
  std::string method;   // GET, POST
  std::string pattern;  // "/api/v1/measurements/{id}"
  std::string summary;
  bool needs_token = true;
  std::function<Response(const Request&)> handler;
  nlohmann::json openapi;     // operation object extras: parameters, requestBody, responses
  bool streams_body = false;  // the handler reads the body itself, piece by piece (unbounded)
};

// Called before every route's handler (access control sits here); throws to refuse.
using RequestHook = std::function<void(const Request&, const Route&)>;

class Router {
 public:
  void Add(Route r) { routes_.push_back(std::move(r)); }
  void SetHook(RequestHook hook) { hook_ = std::move(hook); }
  const std::vector<Route>& routes() const { return routes_; }
  // Whether the route for this method and path reads its body as a stream.
  bool StreamsBody(const std::string& method, const std::string& path) const;

  // Finds the route, runs the hook and the handler, maps every exception to a problem+json
  // response in one place. Never throws.
  Response Dispatch(Request& req) const;

 private:
  std::vector<Route> routes_;
  RequestHook hook_;
};

// RFC 7807 problem document.
Response Problem(int status, const std::string& title, const std::string& detail,
                 const nlohmann::json& extra = nlohmann::json::object());

// OpenAPI 3 document made from the route table.
nlohmann::json OpenApiDocument(const Router& router, const std::string& version);

}  // namespace km::api
