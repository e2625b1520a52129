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
#include "api/http_options.h"

namespace km::api {

struct RequestRecord;  // api/metrics.h

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
