// A service on its own SQLite file (removed afterwards) with every route added (api/routes.h),
// for route tests that dispatch requests to the router without HTTP.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include "api/routes.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::api::test {

class RoutedServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    db_ = std::filesystem::temp_directory_path() /
          ("km-routes-" + std::to_string(::getpid()) + "-" + info->test_suite_name() + ".db");
    std::filesystem::remove(db_);
    svc_ = std::make_unique<server::Service>(std::make_unique<server::SqliteStorage>(db_.string()),
                                             Options());
    server::RegisterBuiltinKinds(svc_->measurements());
    AddRoutes(router_, *svc_);
  }
  // The service's options; a test that stores jobs by hand keeps the workers from running them.
  virtual server::ServiceOptions Options() const { return {}; }
  void TearDown() override {
    svc_.reset();
    std::filesystem::remove(db_);
  }
  std::filesystem::path db_;
  std::unique_ptr<server::Service> svc_;
  Router router_;
};

}  // namespace km::api::test
