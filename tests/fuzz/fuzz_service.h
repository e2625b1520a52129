// A Service on an in-memory SQLite database for the targets that drive the service core. The
// service keeps what inputs store, so it is replaced by a fresh, freshly seeded one every
// `max_uses` inputs: memory stays bounded and stored state cannot pile up over a long run.
#pragma once

#include <cstddef>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <string>

#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::fuzz {

inline std::unique_ptr<server::Service> NewService() {
  auto service = std::make_unique<server::Service>(
      std::make_unique<server::SqliteStorage>(":memory:"), server::ServiceOptions{});
  server::RegisterBuiltinKinds(service->measurements());
  return service;
}

// A file of the source tree (test fixtures used as seed data), "" when it cannot be read.
inline std::string SourceFile(const std::string& relative) {
  std::ifstream in(std::string(KM_SOURCE_DIR) + "/" + relative, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class RecycledService {
 public:
  using Seed = std::function<void(server::Service&)>;
  RecycledService(std::size_t max_uses, Seed seed) : max_uses_(max_uses), seed_(std::move(seed)) {}

  server::Service& Get() {
    if (!service_ || uses_ >= max_uses_) {
      service_.reset();
      service_ = NewService();
      if (seed_) seed_(*service_);
      uses_ = 0;
    }
    ++uses_;
    return *service_;
  }

 private:
  std::size_t max_uses_;
  Seed seed_;
  std::size_t uses_ = 0;
  std::unique_ptr<server::Service> service_;
};

}  // namespace km::fuzz
