// Request framing and the share of connections a client gets, against a real server on a
// loopback port: a Transfer-Encoding that does not end in `chunked` is refused and its
// connection closed (no byte of its body runs as a second request), duplicated Host and
// Authorization headers are refused, an HTTP/1.1 request needs a Host, the Bearer scheme is
// read in any letter case, and half-open connections cannot shut other clients out.
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "api/connection_registry.h"
#include "api/http_framing.h"
#include "api/http_server.h"
#include "api/http_session.h"
#include "server/base/errors.h"
#include "tests/unit/api/loopback_server.h"
#include "tests/unit/api/raw_client.h"

namespace km::api {
namespace {

using namespace std::chrono_literals;
using test::RawConnection;
using test::StatusOf;
using Headers = std::vector<std::pair<std::string, std::string>>;

TEST(Framing, TransferEncodingMustEndInChunked) {
  const Headers host = {{"host", "x"}};
  const auto with = [&](std::string te) {
    Headers h = host;
    h.emplace_back("transfer-encoding", std::move(te));
    return CheckFraming(h, 11);
  };
  EXPECT_FALSE(with("chunked"));
  EXPECT_FALSE(with("Chunked"));
  for (const char* te : {"gzip", "identity", "chunked, identity", "xchunked", "chunked;x", ""}) {
    const auto r = with(te);
    ASSERT_TRUE(r) << te;
    EXPECT_EQ(r->status, 400) << te;
  }
  for (const char* te : {"gzip, chunked", "chunked, chunked"}) {
    const auto r = with(te);
    ASSERT_TRUE(r) << te;
    EXPECT_EQ(r->status, 501) << te;
  }
  // Two fields are one list: "chunked" then "gzip" ends in gzip.
  Headers two = host;
  two.emplace_back("transfer-encoding", "chunked");
  two.emplace_back("transfer-encoding", "gzip");
  EXPECT_EQ(CheckFraming(two, 11)->status, 400);
  Headers both = host;
  both.emplace_back("transfer-encoding", "chunked");
  both.emplace_back("content-length", "5");
  EXPECT_EQ(CheckFraming(both, 11)->status, 400);
  Headers old = {{"transfer-encoding", "chunked"}};
  EXPECT_EQ(CheckFraming(old, 10)->status, 400);
}

TEST(Framing, HostAuthorizationAndLengthOnce) {
  EXPECT_FALSE(CheckFraming({{"host", "x"}}, 11));
  EXPECT_FALSE(CheckFraming({}, 10));  // HTTP/1.0 may leave Host out
  EXPECT_EQ(CheckFraming({}, 11)->status, 400);
  EXPECT_EQ(CheckFraming({{"host", "x"}, {"host", "y"}}, 11)->status, 400);
  EXPECT_EQ(CheckFraming({{"host", "x"}, {"host", "x"}}, 10)->status, 400);
  EXPECT_EQ(CheckFraming(
                {{"host", "x"}, {"authorization", "Bearer a"}, {"authorization", "Bearer b"}}, 11)
                ->status,
            400);
  EXPECT_EQ(
      CheckFraming({{"host", "x"}, {"content-length", "1"}, {"content-length", "1"}}, 11)->status,
      400);
}

TEST(Framing, BearerSchemeInAnyCase) {
  EXPECT_EQ(BearerToken("Bearer abc"), "abc");
  EXPECT_EQ(BearerToken("bearer abc"), "abc");
  EXPECT_EQ(BearerToken("BEARER   abc"), "abc");
  EXPECT_FALSE(BearerToken("Bearer"));
  EXPECT_FALSE(BearerToken("Bearer "));
  EXPECT_FALSE(BearerToken("Bearerabc"));
  EXPECT_FALSE(BearerToken("Basic abc"));
  EXPECT_FALSE(BearerToken("Bearer\tabc"));
}

TEST(ConnectionShare, AClientOverItsShareGivesUpItsOwnOldestWaitingConnection) {
  ConnectionRegistry r;
  std::vector<int> evicted;
  std::vector<std::uint64_t> ids;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(r.Admit("a", 100, 3));
    ids.push_back(r.Open("a"));
    r.Waiting(ids.back(), [&evicted, i] { evicted.push_back(i); });
  }
  r.Busy(ids[0]);  // a request under way is never cut off
  ASSERT_TRUE(r.Admit("a", 100, 3));
  EXPECT_EQ(evicted, std::vector<int>{1});
  EXPECT_TRUE(r.Admit("b", 100, 3));  // another client is not touched
  EXPECT_EQ(evicted.size(), 1u);
  r.Busy(ids[2]);
  EXPECT_FALSE(r.Admit("a", 100, 3)) << "no waiting connection left to give up";
  for (auto id : ids) r.Close(id);
  EXPECT_EQ(r.Total(), 0u);
}

TEST(ConnectionShare, AtTheCapTheAddressHoldingMostGivesWay) {
  ConnectionRegistry r;
  std::vector<std::string> evicted;
  const auto open = [&](const std::string& a) {
    ASSERT_TRUE(r.Admit(a, 5, 100));
    r.Waiting(r.Open(a), [&evicted, a] { evicted.push_back(a); });
  };
  open("small");
  for (int i = 0; i < 4; ++i) open("big");
  ASSERT_TRUE(r.Admit("new", 5, 100));
  EXPECT_EQ(evicted, std::vector<std::string>{"big"});
}

class FramingServer : public ::testing::Test {
 protected:
  void Start(HttpOptions o = {}) {
    test::RaiseOpenFileLimit();
    router_.Add(Route{"GET", "/healthz", "", false, [](const Request&) {
                        return Response::Json({{"status", "ok"}});
                      }});
    router_.Add(Route{"GET", "/secret", "", true, [this](const Request&) {
                        ++secrets_;
                        return Response::Json({{"secret", true}});
                      }});
    router_.Add(Route{"POST", "/upload", "", true, [this](const Request& r) {
                        ++uploads_;
                        return Response::Json({{"bytes", r.body.size()}});
                      }});
    router_.SetHook([](const Request& req, const Route& route) {
      if (route.needs_token && req.Header("authorization") != "Bearer good") {
        throw server::Unauthorized("token needed");
      }
    });
    server_ = std::make_unique<test::LoopbackServer>(router_, o);
    port_ = server_->port();
  }
  void TearDown() override { server_.reset(); }
  std::optional<std::string> Send(const std::string& bytes) {
    RawConnection c(port_);
    if (!c.Send(bytes)) return {};
    return c.ReadResponse(3s);
  }

  Router router_;
  std::unique_ptr<test::LoopbackServer> server_;
  int port_ = 0;
  std::atomic<int> secrets_{0}, uploads_{0};
};

TEST_F(FramingServer, ABodyOfUnknownLengthIsNeverRunAsASecondRequest) {
  Start();
  const std::string smuggled =
      "GET /secret HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\n\r\n";
  for (const std::string te : {"gzip", "identity", "chunked, identity", "xchunked"}) {
    RawConnection c(port_);
    ASSERT_TRUE(
        c.Send("POST /upload HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\n"
               "Transfer-Encoding: " +
               te + "\r\n\r\n" + smuggled));
    const auto r = c.ReadResponse(3s);
    ASSERT_TRUE(r) << te;
    EXPECT_EQ(StatusOf(*r), 400) << te << "\n" << *r;
    EXPECT_NE(r->find("Connection: close"), std::string::npos) << *r;
    EXPECT_TRUE(c.ClosedWithin(3s)) << te;
  }
  EXPECT_EQ(secrets_.load(), 0) << "a body was run as a request";
  EXPECT_EQ(uploads_.load(), 0);
  const auto chunked = Send(
      "POST /upload HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer good\r\n"
      "Transfer-Encoding: chunked\r\nConnection: close\r\n\r\n3\r\nabc\r\n0\r\n\r\n");
  ASSERT_TRUE(chunked);
  EXPECT_EQ(StatusOf(*chunked), 200) << *chunked;
  EXPECT_NE(chunked->find("\"bytes\":3"), std::string::npos);
}

TEST_F(FramingServer, DuplicatedOrMissingIdentityHeadersAre400) {
  Start();
  const auto two_auth = Send(
      "GET /secret HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer bad\r\n"
      "Authorization: Bearer good\r\n\r\n");
  ASSERT_TRUE(two_auth);
  EXPECT_EQ(StatusOf(*two_auth), 400);
  const auto no_host = Send("GET /healthz HTTP/1.1\r\nConnection: close\r\n\r\n");
  ASSERT_TRUE(no_host);
  EXPECT_EQ(StatusOf(*no_host), 400);
  const auto two_hosts = Send("GET /healthz HTTP/1.1\r\nHost: a\r\nHost: b\r\n\r\n");
  ASSERT_TRUE(two_hosts);
  EXPECT_EQ(StatusOf(*two_hosts), 400);
  const auto http10 = Send("GET /healthz HTTP/1.0\r\n\r\n");
  ASSERT_TRUE(http10);
  EXPECT_EQ(StatusOf(*http10), 200);
  EXPECT_EQ(secrets_.load(), 0);
}

// More half-open connections than the server holds, from one address: every other request
// (the same address, as on a shared proxy) is still answered at once.
TEST_F(FramingServer, HalfOpenRequestsCannotShutOthersOut) {
  HttpOptions o;
  o.max_connections = 64;
  o.max_connections_per_client = 48;
  Start(o);
  std::vector<RawConnection> half;
  for (int i = 0; i < 80; ++i) {
    half.emplace_back(port_);
    half.back().Send("GET /healthz HTTP/1.1\r\nHo");
  }
  for (int i = 0; i < 5; ++i) {
    const auto r = Send("GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    ASSERT_TRUE(r) << "no answer while 80 half-open requests are held";
    EXPECT_EQ(StatusOf(*r), 200) << *r;
    half.emplace_back(port_);
    half.back().Send("GET /healthz HTTP/1.1\r\nHo");
  }
}

// The dashboard's files: a symbolic link below the web root to a file outside it is not served;
// links within it, and a root that is itself a link, are.
TEST(StaticFiles, LinksOutOfTheWebRootAreNotServed) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("km-static-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "web");
  std::ofstream(dir / "secret.txt") << "key";
  std::ofstream(dir / "web" / "index.html") << "<html></html>";
  std::ofstream(dir / "web" / "app.js") << "1;";
  fs::create_symlink(dir / "secret.txt", dir / "web" / "leak.txt");
  fs::create_symlink(dir / "web" / "app.js", dir / "web" / "alias.js");
  fs::create_directory_symlink(dir, dir / "web" / "up");
  fs::create_directory_symlink(dir / "web", dir / "link-root");
  const std::string root = (dir / "web").string();
  EXPECT_EQ(ServeStatic(root, "/static/leak.txt").status, 404);
  EXPECT_EQ(ServeStatic(root, "/static/up/secret.txt").status, 404);
  EXPECT_EQ(ServeStatic(root, "/static/alias.js").status, 200);
  EXPECT_EQ(ServeStatic(root, "/").status, 200);
  EXPECT_EQ(ServeStatic((dir / "link-root").string(), "/static/app.js").body, "1;");
  EXPECT_EQ(ServeStatic((dir / "link-root").string(), "/static/leak.txt").status, 404);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace km::api
