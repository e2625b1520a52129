// The HTTP server: Boost.Beast on an Asio event loop, handlers on a worker pool. Sockets are
// read and written asynchronously by the event loop, so idle, slow or streaming clients hold no
// thread; only a complete request (or one piece of a streamed body) occupies a worker. Every
// limit is explicit: connections (more are refused with 503), header size and deadline, idle
// keep-alive deadline, body size and inactivity deadline, write deadline, requests per
// connection, and the queue of requests waiting for a worker (full: 503 with Retry-After).
// Access is checked from the headers before any body is read.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "api/http.h"

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
  std::size_t max_connections = 4096;
  int backlog = 1024;       // listen backlog (the kernel caps it at somaxconn)
  std::string static_root;  // dashboard files (served at "/" and "/static/…")
  // Web origins allowed to call the API from a browser (CORS); others get no CORS headers and
  // their preflight requests are refused with 403. Default: none.
  std::vector<std::string> cors_origins;
  // Told of every answer as it is written (e.g. the access log); runs on the event loop, so it
  // must be quick and must not throw.
  std::function<void(const RequestRecord&)> on_answer;
};

class HttpServer {
 public:
  HttpServer(const Router& router, HttpOptions options);
  ~HttpServer();
  // Binds and listens; returns the port (useful with port 0). Throws km::Error when it cannot.
  int Bind();
  // Serves until Stop(); blocks.
  void Serve();
  // Stops accepting and serving; safe from any thread, also before Serve.
  void Stop();
  // Graceful stop: stops accepting, answers new requests on open connections 503, waits until
  // the requests in flight are answered (at most `grace`), then Stop(). Returns how many requests
  // were still in flight when it gave up (0: all were answered). Call from another thread than
  // Serve's.
  std::int64_t Shutdown(std::chrono::milliseconds grace);
  // Requests whose headers were read and whose answer is not yet written.
  std::int64_t InFlight() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace km::api
