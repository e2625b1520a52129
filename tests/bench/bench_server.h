// A real kinemetric server inside a benchmark process: the service on a SQLite file (WAL,
// synchronous=FULL), every route, token checks, and the HTTP server on a free loopback port,
// serving from its own thread until the object is destroyed. The admin token is "bench".
#pragma once

#include <filesystem>
#include <memory>
#include <thread>

#include "api/http_server.h"
#include "api/routes.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::bench {

class BenchServer {
 public:
  explicit BenchServer(const std::filesystem::path& db)
      : service_(std::make_unique<server::SqliteStorage>(db.string()), {}) {
    server::RegisterBuiltinKinds(service_.measurements());
    api::EnsureAdminToken(service_.storage(), "bench");
    api::AddRoutes(router_, service_);
    router_.SetHook(api::TokenHook(service_.storage()));
    api::HttpOptions o;
    o.port = 0;
    http_ = std::make_unique<api::HttpServer>(router_, o);
    port_ = http_->Bind();
    serve_ = std::thread([this] { http_->Serve(); });
  }
  ~BenchServer() {
    http_->Stop();
    serve_.join();
  }
  BenchServer(const BenchServer&) = delete;
  BenchServer& operator=(const BenchServer&) = delete;

  server::Service& service() { return service_; }
  int port() const { return port_; }

 private:
  server::Service service_;
  api::Router router_;
  std::unique_ptr<api::HttpServer> http_;
  int port_ = 0;
  std::thread serve_;
};

}  // namespace km::bench
