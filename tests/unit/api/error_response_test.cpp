// The mapping of exceptions to answers (api/http.cpp ErrorResponse): internal failures are
// logged with the request id and answered without their text; a busy database is 503 with
// Retry-After, any other storage failure 500.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <iostream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "api/http.h"
#include "server/storage/storage.h"

namespace km::api {
namespace {

// Captures std::cerr for the lifetime of the object.
class CerrCapture {
 public:
  CerrCapture() : old_(std::cerr.rdbuf(buf_.rdbuf())) {}
  ~CerrCapture() { std::cerr.rdbuf(old_); }
  std::string text() const { return buf_.str(); }

 private:
  std::ostringstream buf_;
  std::streambuf* old_;
};

Request MakeRequest() {
  Request req;
  req.method = "GET";
  req.path = "/api/v1/jobs";
  req.id = "req-42";
  return req;
}

Response Answer(std::exception_ptr e, std::string* log) {
  CerrCapture capture;
  Response r = ErrorResponse(std::move(e), MakeRequest());
  *log = capture.text();
  return r;
}

TEST(ErrorResponse, InternalFailureIsLoggedWithTheRequestIdAndNeverEchoed) {
  const std::string secret = "cannot open /var/lib/kinemetric/secret.db: SELECT * FROM tokens";
  std::string log;
  const Response r = Answer(std::make_exception_ptr(std::runtime_error(secret)), &log);
  EXPECT_EQ(r.status, 500);
  EXPECT_EQ(r.content_type, "application/problem+json");
  EXPECT_EQ(r.body.find("secret"), std::string::npos) << r.body;
  EXPECT_EQ(r.body.find("tokens"), std::string::npos) << r.body;
  const auto j = nlohmann::json::parse(r.body);
  EXPECT_EQ(j["status"], 500);
  EXPECT_EQ(j["request_id"], "req-42");
  EXPECT_NE(j["detail"].get<std::string>().find("req-42"), std::string::npos);
  EXPECT_NE(log.find("req-42"), std::string::npos) << log;
  EXPECT_NE(log.find(secret), std::string::npos) << log;
}

TEST(ErrorResponse, UnknownExceptionIsA500WithTheRequestId) {
  std::string log;
  const Response r = Answer(std::make_exception_ptr(42), &log);
  EXPECT_EQ(r.status, 500);
  EXPECT_EQ(nlohmann::json::parse(r.body)["request_id"], "req-42");
  EXPECT_NE(log.find("req-42"), std::string::npos) << log;
}

TEST(ErrorResponse, StorageErrorThatIsNotBusyIsA500WithoutItsText) {
  std::string log;
  const Response r = Answer(std::make_exception_ptr(server::StorageError(
                                "storage: step: disk I/O error", SQLITE_IOERR, false)),
                            &log);
  EXPECT_EQ(r.status, 500);
  EXPECT_EQ(r.body.find("disk I/O"), std::string::npos) << r.body;
  EXPECT_EQ(r.headers.count("Retry-After"), 0u);
  EXPECT_NE(log.find("disk I/O error"), std::string::npos) << log;
}

TEST(ErrorResponse, BusyOrLockedDatabaseIs503WithRetryAfter) {
  for (const int code : {SQLITE_BUSY, SQLITE_LOCKED}) {
    std::string log;
    const Response r = Answer(std::make_exception_ptr(server::StorageError(
                                  "storage: database is locked (/data/kinemetric.db)", code, true)),
                              &log);
    EXPECT_EQ(r.status, 503) << code;
    EXPECT_EQ(r.content_type, "application/problem+json");
    ASSERT_EQ(r.headers.count("Retry-After"), 1u);
    EXPECT_EQ(r.headers.at("Retry-After"), "1");
    EXPECT_EQ(r.body.find("/data"), std::string::npos) << r.body;
    EXPECT_EQ(nlohmann::json::parse(r.body)["request_id"], "req-42");
    EXPECT_NE(log.find("req-42"), std::string::npos) << log;
  }
}

TEST(ErrorResponse, ExpectedErrorsKeepTheirStatusAndMessage) {
  std::string log;
  EXPECT_EQ(Answer(std::make_exception_ptr(NotFound("measurement 9 does not exist")), &log).status,
            404);
  const Response bad = Answer(std::make_exception_ptr(InvalidInput("f", 3, "x", "bad x")), &log);
  EXPECT_EQ(bad.status, 400);
  EXPECT_NE(bad.body.find("bad x"), std::string::npos);
  const Response full = Answer(std::make_exception_ptr(Unavailable("queue full")), &log);
  EXPECT_EQ(full.status, 503);
  EXPECT_EQ(full.headers.at("Retry-After"), "1");
}

}  // namespace
}  // namespace km::api
