// One client connection of the HTTP server (api/http_server.cpp accepts, this serves).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>

#include <boost/asio/ip/tcp.hpp>

#include "api/connection_registry.h"
#include "api/http.h"
#include "api/http_options.h"
#include "api/worker_pool.h"

namespace km::api {

// What every connection shares: the routes, the limits, the workers and the counters.
struct ServerContext {
  ServerContext(const Router& r, HttpOptions o)
      : router(r), options(std::move(o)), pool(options.threads, options.queue_limit) {}
  const Router& router;
  const HttpOptions options;
  WorkerPool pool;
  std::atomic<std::size_t> connections{0};
  ConnectionRegistry registry;  // connections by client address, and which may make room
  std::atomic<std::uint64_t> requests{0};
  // Requests whose headers were read and whose answer is not yet written (graceful shutdown
  // waits for them); while stopping, new requests on open connections are answered 503.
  std::atomic<std::int64_t> in_flight{0};
  std::atomic<bool> stopping{false};
  std::string request_id_prefix;  // random per server start, so ids do not repeat across starts

  std::string NextRequestId();
};

// Serves requests on the socket until the client closes, a deadline passes or a limit is hit.
void StartSession(boost::asio::ip::tcp::socket socket, std::string address, ServerContext& context);

// The dashboard files: "/" is index.html, "/static/NAME" a plain file below `root`.
Response ServeStatic(const std::string& root, const std::string& path);

}  // namespace km::api
