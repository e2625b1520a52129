// The HTTP layer against hostile and careless clients: idle and slow connections, bodies sent
// without a token, full queues, the connection cap, streamed bodies, bad targets, leaked
// internals. A real server on a loopback port, with test routes.
#include "api/http_server.h"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <memory>
#include <thread>
#include <vector>

#include "analysis/core/errors.h"
#include "server/base/errors.h"
#include "tests/unit/api/loopback_server.h"
#include "tests/unit/api/raw_client.h"

namespace km::api {
namespace {

using namespace std::chrono_literals;
using test::RawConnection;
using test::StatusOf;

class BlockGate {
 public:
  void Open() {
    std::lock_guard lock(mu_);
    open_ = true;
    cv_.notify_all();
  }
  void Wait() {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return open_; });
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool open_ = false;
};

// Counts the bytes of a streamed body.
class CountingSink : public BodySink {
 public:
  explicit CountingSink(std::atomic<std::size_t>& fed) : fed_(fed) {}
  void Feed(std::string_view piece) override {
    if (piece.find("BAD") != std::string_view::npos) throw InvalidInput("", 0, "body", "bad piece");
    fed_ += piece.size();
  }
  Response Finish(bool complete) override {
    return Response::Json({{"complete", complete}, {"bytes", fed_.load()}});
  }

 private:
  std::atomic<std::size_t>& fed_;
};

class HttpServerTest : public ::testing::Test {
 protected:
  void Start(HttpOptions o) {
    test::RaiseOpenFileLimit();
    router_.Add(Route{"GET", "/healthz", "", false, [](const Request&) {
                        return Response::Json({{"status", "ok"}});
                      }});
    router_.Add(Route{"GET", "/block", "", false, [this](const Request&) {
                        ++blocked_;
                        gate_.Wait();
                        return Response::Json({{"released", true}});
                      }});
    router_.Add(Route{"GET", "/boom", "", false, [](const Request&) -> Response {
                        throw std::runtime_error("SQLITE_CORRUPT secret internals");
                      }});
    router_.Add(Route{"POST", "/upload", "", true, [this](const Request& r) {
                        ++uploads_;
                        return Response::Json({{"bytes", r.body.size()}});
                      }});
    Route small{"POST", "/small", "", true, [this](const Request& r) {
                  ++uploads_;
                  return Response::Json({{"bytes", r.body.size()}});
                }};
    small.max_body_bytes = 100;
    router_.Add(std::move(small));
    Route stream{"POST", "/stream", "", true, [](const Request& r) {
                   return Response::Json({{"bytes", r.body.size()}});
                 }};
    stream.open_body = [this](const Request&) { return std::make_unique<CountingSink>(fed_); };
    router_.Add(std::move(stream));
    router_.SetHook([](const Request& req, const Route& route) {
      if (route.needs_token && req.Header("authorization") != "Bearer good") {
        throw server::Unauthorized("token needed");
      }
    });
    server_ = std::make_unique<test::LoopbackServer>(router_, o);
    port_ = server_->port();
  }
  void TearDown() override {
    gate_.Open();
    server_.reset();
  }

  std::optional<std::string> Get(const std::string& path, std::chrono::milliseconds wait = 5s) {
    RawConnection c(port_);
    if (!c.Send("GET " + path + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")) return {};
    return c.ReadResponse(wait);
  }

  Router router_;
  std::unique_ptr<test::LoopbackServer> server_;
  int port_ = 0;
  BlockGate gate_;
  std::atomic<int> blocked_{0}, uploads_{0};
  std::atomic<std::size_t> fed_{0};
};

TEST_F(HttpServerTest, IdleAndSlowHeaderConnectionsDoNotSilenceTheServer) {
  HttpOptions o;
  o.threads = 2;
  Start(o);
  std::vector<RawConnection> idle;
  for (int i = 0; i < 1000; ++i) idle.emplace_back(port_);
  std::vector<RawConnection> slow;
  for (int i = 0; i < 100; ++i) {
    slow.emplace_back(port_);
    slow.back().Send("GET /healthz HTTP/1.1\r\nHo");
  }
  for (int i = 0; i < 5; ++i) {
    const auto r = Get("/healthz");
    ASSERT_TRUE(r) << "no answer while 1000 idle and 100 slow connections are open";
    EXPECT_EQ(StatusOf(*r), 200);
  }
}

TEST_F(HttpServerTest, HeadersMustArriveBeforeTheHeaderDeadline) {
  HttpOptions o;
  o.header_timeout_s = 1;
  Start(o);
  RawConnection c(port_);
  c.Send("GET /healthz HTTP/1.1\r\n");
  EXPECT_TRUE(c.ClosedWithin(4s));
}

TEST_F(HttpServerTest, TokenIsCheckedBeforeTheBodyIsRead) {
  Start({});
  RawConnection c(port_);
  // 30 MB announced, nothing sent: the refusal comes at once, from the headers alone.
  c.Send("POST /upload HTTP/1.1\r\nHost: x\r\nContent-Length: 31457280\r\n\r\n");
  const auto r = c.ReadResponse(3s);
  ASSERT_TRUE(r);
  EXPECT_EQ(StatusOf(*r), 401);
  EXPECT_EQ(uploads_.load(), 0);
}

TEST_F(HttpServerTest, OversizedBodyIsRefusedWithoutReadingIt) {
  HttpOptions o;
  o.max_payload_bytes = 1000;
  Start(o);
  RawConnection c(port_);
  c.Send(
      "POST /upload HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\n"
      "Content-Length: 5000\r\n\r\n");
  const auto r = c.ReadResponse(3s);
  ASSERT_TRUE(r);
  EXPECT_EQ(StatusOf(*r), 413);
  // Chunked bodies are capped too.
  RawConnection d(port_);
  d.Send(
      "POST /upload HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\n"
      "Transfer-Encoding: chunked\r\n\r\n7d0\r\n" +
      std::string(2000, 'a') + "\r\n");
  const auto r2 = d.ReadResponse(3s);
  ASSERT_TRUE(r2);
  EXPECT_EQ(StatusOf(*r2), 413);
  EXPECT_EQ(uploads_.load(), 0);
}

TEST_F(HttpServerTest, ARouteMayHaveASmallerBodyLimitThanTheServer) {
  Start({});
  RawConnection c(port_);
  c.Send(
      "POST /small HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\n"
      "Content-Length: 500\r\n\r\n");
  const auto r = c.ReadResponse(3s);
  ASSERT_TRUE(r);
  EXPECT_EQ(StatusOf(*r), 413);
  EXPECT_NE(r->find("exceeds 100 bytes"), std::string::npos) << *r;
  RawConnection d(port_);
  d.Send(
      "POST /small HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\n"
      "Transfer-Encoding: chunked\r\n\r\nc8\r\n" +
      std::string(200, 'a') + "\r\n");
  const auto r2 = d.ReadResponse(3s);
  ASSERT_TRUE(r2);
  EXPECT_EQ(StatusOf(*r2), 413);
  EXPECT_EQ(uploads_.load(), 0);
  // Within the limit; and other routes keep the server's limit.
  RawConnection e(port_);
  e.Send(
      "POST /small HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\nConnection: close\r\n"
      "Content-Length: 100\r\n\r\n" +
      std::string(100, 'b'));
  const auto r3 = e.ReadResponse(3s);
  ASSERT_TRUE(r3);
  EXPECT_EQ(StatusOf(*r3), 200);
  RawConnection f(port_);
  f.Send(
      "POST /upload HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\nConnection: close\r\n"
      "Content-Length: 500\r\n\r\n" +
      std::string(500, 'c'));
  const auto r4 = f.ReadResponse(3s);
  ASSERT_TRUE(r4);
  EXPECT_EQ(StatusOf(*r4), 200);
  EXPECT_EQ(uploads_.load(), 2);
  // Callers that pass the whole body to the router meet the same limit.
  Request big;
  big.method = "POST";
  big.path = "/small";
  big.headers["authorization"] = "Bearer good";
  big.body = std::string(101, 'd');
  EXPECT_EQ(router_.Dispatch(big).status, 413);
  EXPECT_EQ(uploads_.load(), 2);
}

TEST_F(HttpServerTest, FullQueueAnswers503WithRetryAfter) {
  HttpOptions o;
  o.threads = 1;
  o.queue_limit = 1;
  Start(o);
  RawConnection a(port_), b(port_);
  a.Send("GET /block HTTP/1.1\r\nHost: x\r\n\r\n");
  while (blocked_.load() == 0) std::this_thread::sleep_for(5ms);
  b.Send("GET /block HTTP/1.1\r\nHost: x\r\n\r\n");  // waits in the queue
  std::this_thread::sleep_for(100ms);
  const auto r = Get("/healthz");
  ASSERT_TRUE(r);
  EXPECT_EQ(StatusOf(*r), 503);
  EXPECT_NE(r->find("Retry-After: 1"), std::string::npos);
  gate_.Open();
  const auto ra = a.ReadResponse(3s), rb = b.ReadResponse(3s);
  ASSERT_TRUE(ra && rb);
  EXPECT_EQ(StatusOf(*ra), 200);
  EXPECT_EQ(StatusOf(*rb), 200);
}

// Beyond the cap, a newcomer takes the place of a connection waiting for its headers
// (tests/unit/api/http_framing_test.cpp); when every connection is busy with a request, it is
// refused clearly.
TEST_F(HttpServerTest, ConnectionsBeyondTheCapAreRefusedClearly) {
  HttpOptions o;
  o.max_connections = 4;
  Start(o);
  std::vector<RawConnection> held;
  for (int i = 0; i < 4; ++i) {
    held.emplace_back(port_);
    held.back().Send("GET /block HTTP/1.1\r\nHost: x\r\n\r\n");
  }
  while (blocked_.load() < 4) std::this_thread::sleep_for(5ms);
  const auto r = Get("/healthz");
  ASSERT_TRUE(r);
  EXPECT_EQ(StatusOf(*r), 503);
  EXPECT_NE(r->find("too many connections"), std::string::npos);
  gate_.Open();
  for (auto& c : held) EXPECT_TRUE(c.ReadResponse(3s));
  held.clear();
  std::this_thread::sleep_for(100ms);
  const auto after = Get("/healthz");
  ASSERT_TRUE(after);
  EXPECT_EQ(StatusOf(*after), 200);
}

TEST_F(HttpServerTest, SlowStreamedBodyHoldsNoWorker) {
  HttpOptions o;
  o.threads = 1;
  Start(o);
  RawConnection s(port_);
  s.Send(
      "POST /stream HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\n"
      "Transfer-Encoding: chunked\r\n\r\n5\r\nhello\r\n");
  std::this_thread::sleep_for(100ms);
  // The only worker is free while the stream waits for its next piece.
  for (int i = 0; i < 3; ++i) {
    const auto r = Get("/healthz", 2s);
    ASSERT_TRUE(r);
    EXPECT_EQ(StatusOf(*r), 200);
  }
  s.Send("6\r\n world\r\n0\r\n\r\n");
  const auto r = s.ReadResponse(3s);
  ASSERT_TRUE(r);
  EXPECT_EQ(StatusOf(*r), 200);
  EXPECT_NE(r->find("\"bytes\":11"), std::string::npos) << *r;
  EXPECT_NE(r->find("\"complete\":true"), std::string::npos);
}

TEST_F(HttpServerTest, StreamRefusedMidwayAnswersTheReason) {
  Start({});
  RawConnection s(port_);
  s.Send(
      "POST /stream HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\n"
      "Transfer-Encoding: chunked\r\n\r\n3\r\nBAD\r\n");
  const auto r = s.ReadResponse(3s);
  ASSERT_TRUE(r);
  EXPECT_EQ(StatusOf(*r), 400);
  EXPECT_NE(r->find("bad piece"), std::string::npos);
}

TEST_F(HttpServerTest, ServerErrorsNameARequestIdAndNothingElse) {
  Start({});
  const auto r = Get("/boom");
  ASSERT_TRUE(r);
  EXPECT_EQ(StatusOf(*r), 500);
  EXPECT_EQ(r->find("SQLITE"), std::string::npos) << *r;
  EXPECT_EQ(r->find("secret"), std::string::npos);
  const auto id_at = r->find("X-Request-Id: ");
  ASSERT_NE(id_at, std::string::npos);
  const std::string id = r->substr(id_at + 14, r->find("\r\n", id_at) - id_at - 14);
  EXPECT_NE(r->find("\"request_id\":\"" + id + "\""), std::string::npos) << *r;
}

TEST_F(HttpServerTest, BadTargetsAndSecurityHeaders) {
  Start({});
  const auto nul = Get("/static/index.html%00.png");
  ASSERT_TRUE(nul);
  EXPECT_EQ(StatusOf(*nul), 400);
  EXPECT_EQ(nul->find("image/png"), std::string::npos);
  const auto bad_utf8 = Get("/healthz?x=%C0%AF");
  ASSERT_TRUE(bad_utf8);
  EXPECT_EQ(StatusOf(*bad_utf8), 400);
  const auto ok = Get("/healthz");
  ASSERT_TRUE(ok);
  EXPECT_NE(ok->find("X-Content-Type-Options: nosniff"), std::string::npos);
  EXPECT_NE(ok->find("Content-Security-Policy: "), std::string::npos);
  const auto missing = Get("/nowhere");
  ASSERT_TRUE(missing);
  EXPECT_EQ(StatusOf(*missing), 404);
}

TEST_F(HttpServerTest, KeepAliveServesManyRequestsOnOneConnection) {
  Start({});
  RawConnection c(port_);
  for (int i = 0; i < 50; ++i) {
    ASSERT_TRUE(c.Send("GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n"));
    const auto r = c.ReadResponse(2s);
    ASSERT_TRUE(r) << "request " << i;
    EXPECT_EQ(StatusOf(*r), 200);
  }
  ASSERT_TRUE(c.Send("HEAD /healthz HTTP/1.1\r\nHost: x\r\n\r\n"));
  // HEAD: the headers of the GET answer (its Content-Length), no body.
  const auto h = c.ReadResponse(500ms);
  EXPECT_FALSE(h);  // ReadResponse waits for Content-Length bytes that never come
}

TEST_F(HttpServerTest, GarbageIsAnsweredWith400AndTheServerLivesOn) {
  Start({});
  RawConnection c(port_);
  c.Send("\x16\x03\x01\x02\x00garbage\r\n\r\n");
  const auto r = c.ReadResponse(2s);
  ASSERT_TRUE(r);
  EXPECT_EQ(StatusOf(*r), 400);
  RawConnection big(port_);
  big.Send("GET /healthz HTTP/1.1\r\nX-Big: " + std::string(40000, 'a') + "\r\n\r\n");
  const auto r2 = big.ReadResponse(2s);
  ASSERT_TRUE(r2);
  EXPECT_EQ(StatusOf(*r2), 431);
  const auto ok = Get("/healthz");
  ASSERT_TRUE(ok);
  EXPECT_EQ(StatusOf(*ok), 200);
}

}  // namespace
}  // namespace km::api
