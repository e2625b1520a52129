// The HTTP server: cpp-httplib behind the project's own types. Limits are explicit: payload
// size, read/write timeouts, keep-alive count and timeout, worker threads, and a bounded queue
// of accepted connections (the acceptor waits when it is full, so the kernel backlog absorbs
// bursts instead of unbounded memory).
#pragma once

#include <atomic>
#include <memory>
#include <string>

#include "api/http.h"

namespace km::api {

struct HttpOptions {
  std::string host = "127.0.0.1";
  int port = 8080;  // 0: any free port
  std::size_t max_payload_bytes = 32u << 20;
  int read_timeout_s = 10;
  int write_timeout_s = 10;
  int keep_alive_max_count = 100;
  int keep_alive_timeout_s = 5;
  int threads = 8;
  std::size_t queue_limit = 64;
  std::string static_root;  // dashboard files (served at "/" and "/static/…")
};

class HttpServer {
 public:
  HttpServer(const Router& router, HttpOptions options);
  ~HttpServer();
  // Binds; returns the port (useful with port 0). Throws km::Error when it cannot bind.
  int Bind();
  // Serves until Stop(); blocks.
  void Serve();
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace km::api
