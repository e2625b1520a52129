// The HTTP server's settings: where it listens, its limits and deadlines, its threads, the
// dashboard's files and the web origins allowed to call it (api/http_server.h).
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace km::api {

struct RequestRecord;  // api/metrics.h

struct HttpOptions {
  std::string host = "127.0.0.1";
  int port = 8080;  // 0: any free port
  std::size_t max_payload_bytes = 32u << 20;
  std::size_t max_header_bytes = 16u << 10;
  int header_timeout_s = 10;  // the request line and headers must arrive within this
  int read_timeout_s = 10;    // a body may pause at most this long between pieces
  int write_timeout_s = 10;   // an answer must be taken by the client within this
  int keep_alive_max_count = 1000;
  int keep_alive_timeout_s = 5;  // an idle keep-alive connection is closed after this
  int threads = 8;               // handler (worker) threads
  int io_threads = 1;            // event-loop threads
  std::size_t queue_limit = 64;  // requests waiting for a worker; more get 503
  // Open connections in all, and of one client address. A newcomer beyond either takes the
  // place of a connection waiting for its headers (api/connection_registry.h); it gets 503 only
  // when every connection it could replace is busy with a request.
  std::size_t max_connections = 4096;
  std::size_t max_connections_per_client = 1024;
  int backlog = 1024;       // listen backlog (the kernel caps it at somaxconn)
  std::string static_root;  // dashboard files (served at "/" and "/static/…")
  // Web origins allowed to call the API from a browser (CORS); others get no CORS headers and
  // their preflight requests are refused with 403. Default: none.
  std::vector<std::string> cors_origins;
  // Told of every answer as it is written (e.g. the access log); runs on the event loop, so it
  // must be quick and must not throw.
  std::function<void(const RequestRecord&)> on_answer;
};

}  // namespace km::api
