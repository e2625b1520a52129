// Body limits of the study routes (api/route_util.h WithBodyLimit): a calibration, discovery or
// servo request names stored measurements, so a body far above what such a request needs is
// refused 413 before it is parsed; a calibration may still carry a whole machine definition
// (up to the model limit) inline.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "api/route_util.h"
#include "api/routes.h"
#include "server/service.h"
#include "server/sqlite_storage.h"

namespace km::api {
namespace {

namespace fs = std::filesystem;

class BodyLimits : public ::testing::Test {
 protected:
  void SetUp() override {
    db_ = fs::temp_directory_path() / ("km-body-limits-" + std::to_string(::getpid()) + ".db");
    fs::remove(db_);
    svc_ = std::make_unique<server::Service>(std::make_unique<server::SqliteStorage>(db_.string()),
                                             server::ServiceOptions{});
    server::RegisterBuiltinKinds(*svc_);
    AddRoutes(router_, *svc_);
  }
  void TearDown() override {
    svc_.reset();
    fs::remove(db_);
  }
  // The status of a POST whose JSON body is padded to `bytes` with a long string field.
  int Post(const std::string& path, std::size_t bytes) {
    const std::string head = R"({"measurement_ids": [1], "note": ")", tail = "\"}";
    Request r;
    r.method = "POST";
    r.path = path;
    r.body = head + std::string(bytes - head.size() - tail.size(), 'x') + tail;
    return router_.Dispatch(r).status;
  }
  fs::path db_;
  std::unique_ptr<server::Service> svc_;
  Router router_;
};

TEST_F(BodyLimits, StudyRequestsAboveTheirLimitAre413BeforeParsing) {
  for (const char* path :
       {"/api/v1/discoveries", "/api/v1/servo/joints", "/api/v1/servo/identify"}) {
    EXPECT_EQ(Post(path, kStudyRequestBytes + 1), 413) << path;
    // Within the limit the request is read and judged on its content (no such measurement).
    const int within = Post(path, kStudyRequestBytes);
    EXPECT_NE(within, 413) << path;
    EXPECT_LT(within, 500) << path;
  }
  const std::size_t calibration = server::kMaxMachineModelBytes + kStudyRequestBytes;
  EXPECT_EQ(Post("/api/v1/calibrations", calibration + 1), 413);
  EXPECT_EQ(Post("/api/v1/calibrations", server::kMaxMachineModelBytes + 1000), 400);
}

}  // namespace
}  // namespace km::api
