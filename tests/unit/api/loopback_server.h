// An HttpServer of a test's router on a free loopback port, served on its own thread until the
// object goes (for tests that speak to it byte by byte, tests/unit/api/raw_client.h).
#pragma once

#include <memory>
#include <thread>

#include "api/http_server.h"

namespace km::test {

class LoopbackServer {
 public:
  LoopbackServer(const api::Router& router, api::HttpOptions options) {
    options.host = "127.0.0.1";
    options.port = 0;
    server_ = std::make_unique<api::HttpServer>(router, options);
    port_ = server_->Bind();
    thread_ = std::thread([this] { server_->Serve(); });
  }
  ~LoopbackServer() {
    server_->Stop();
    thread_.join();
  }
  LoopbackServer(const LoopbackServer&) = delete;
  LoopbackServer& operator=(const LoopbackServer&) = delete;

  int port() const { return port_; }

 private:
  std::unique_ptr<api::HttpServer> server_;
  std::thread thread_;
  int port_ = 0;
};

}  // namespace km::test
