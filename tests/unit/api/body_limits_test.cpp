// Body limits of the study routes (api/route_util.h WithBodyLimit): a calibration, discovery or
// servo request names stored measurements, so a body far above what such a request needs is
// refused 413 before it is parsed; a calibration may still carry a whole machine definition
// (up to the model limit) inline.
#include <string>

#include <gtest/gtest.h>

#include "api/route_util.h"
#include "tests/unit/api/routed_service.h"

namespace km::api {
namespace {

class BodyLimits : public test::RoutedServiceTest {
 protected:
  // The status of a POST whose JSON body is padded to `bytes` with a long string field.
  int Post(const std::string& path, std::size_t bytes) {
    const std::string head = R"({"measurement_ids": [1], "note": ")", tail = "\"}";
    Request r;
    r.method = "POST";
    r.path = path;
    r.body = head + std::string(bytes - head.size() - tail.size(), 'x') + tail;
    return router_.Dispatch(r).status;
  }
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
