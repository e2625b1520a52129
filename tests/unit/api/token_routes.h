// A service on its own SQLite file in a directory of its own (removed afterwards) with every
// route added, tokens checked and the audit log written as the server does (api/access.h hooks),
// for route tests that dispatch requests with a role's token to the router without HTTP. The
// admin token is "boot"; Token(role) makes another.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "api/http_target.h"
#include "api/routes.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::api::test {

class TokenRoutesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ =
        std::filesystem::temp_directory_path() / ("km-routes-" + std::to_string(::getpid()) + "-" +
                                                  info->test_suite_name() + "-" + info->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    svc_ = std::make_unique<server::Service>(
        std::make_unique<server::SqliteStorage>((dir_ / "km.db").string()),
        server::ServiceOptions{});
    server::RegisterBuiltinKinds(svc_->measurements());
    AddRoutes(router_, *svc_);
    router_.SetHook(TokenHook(*svc_));
    router_.SetObserver(AuditHook(*svc_));
    ASSERT_EQ(svc_->access().EnsureAdminToken("boot"), "");
  }
  void TearDown() override {
    svc_.reset();
    std::filesystem::remove_all(dir_);
  }
  // `target` is a path, given to the router as it is, or a path with a query
  // ("/api/v1/…?version=2"), taken apart as the server takes a request target apart.
  Response Call(const std::string& method, const std::string& target, const std::string& token,
                const std::string& body = "") {
    Request req;
    req.method = method;
    req.path = target;
    if (target.find('?') != std::string::npos) {
      std::string error;
      const auto t = ParseTarget(target, error);
      EXPECT_TRUE(t) << target << ": " << error;
      if (t) {
        req.path = t->path;
        req.query = t->query;
      }
    }
    req.headers["authorization"] = "Bearer " + token;
    req.body = body;
    return router_.Dispatch(req);
  }
  // A new token of the role, named `name` (the role's own name when empty).
  std::string Token(const std::string& role, const std::string& name = "") {
    const nlohmann::json body{{"name", name.empty() ? role : name}, {"role", role}};
    const auto r = Call("POST", "/api/v1/tokens", "boot", body.dump());
    EXPECT_EQ(r.status, 201) << r.body;
    return nlohmann::json::parse(r.body)["token"].get<std::string>();
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  std::filesystem::path dir_;
  std::unique_ptr<server::Service> svc_;
  Router router_;
};

}  // namespace km::api::test
