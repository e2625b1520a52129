// Webhook delivery against receivers that misbehave (server/audits/webhook.h, webhook_client.h):
// one that answers a byte at a time ends the attempt at its deadline (not per read) and the next
// verdict still goes out; a stop during such an attempt is prompt; loopback and private
// targets are refused unless allowed, written as such in the URL (at configuration) or
// resolved to one (at delivery).
#include "server/audits/webhook.h"

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "analysis/core/errors.h"
#include "server/base/config.h"
#include "server/base/net_ranges.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server::test {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// A receiver on 127.0.0.1 that answers the first `drips` connections one byte every `every`
// and the others at once with 204; it serves one connection at a time.
class DripReceiver {
 public:
  DripReceiver(int drips, milliseconds every) : drips_(drips), every_(every) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), len) != 0 || ::listen(fd_, 8) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
      ADD_FAILURE() << "cannot listen";
    }
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this] { Serve(); });
  }
  ~DripReceiver() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
  }
  int port() const { return port_; }
  int connections() const { return connections_; }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_) + "/hook"; }

 private:
  bool Readable(int fd) const {
    pollfd p{fd, POLLIN, 0};
    return ::poll(&p, 1, 20) > 0;
  }
  void Serve() {
    while (!stop_) {
      if (!Readable(fd_)) continue;
      const int c = ::accept(fd_, nullptr, nullptr);
      if (c < 0) continue;
      const bool drip = ++connections_ <= drips_;
      ReadRequest(c);
      drip ? Drip(c) : Answer(c);
      ::close(c);
    }
  }
  void ReadRequest(int c) {
    std::string got;
    char buf[4096];
    while (!stop_ && got.find("\r\n\r\n") == std::string::npos) {
      if (!Readable(c)) continue;
      const auto n = ::recv(c, buf, sizeof buf, 0);
      if (n <= 0) return;
      got.append(buf, static_cast<std::size_t>(n));
    }
  }
  void Drip(int c) {
    const std::string answer = "HTTP/1.1 204 No Content\r\nContent-Length: 0\r\n\r\n";
    for (std::size_t i = 0; i < answer.size() && !stop_; ++i) {
      if (::send(c, &answer[i], 1, MSG_NOSIGNAL) != 1) return;
      for (auto t = Clock::now(); Clock::now() - t < every_ && !stop_;) {
        std::this_thread::sleep_for(milliseconds(5));
      }
    }
  }
  static void Answer(int c) {
    const std::string answer = "HTTP/1.1 204 No Content\r\nContent-Length: 0\r\n\r\n";
    ::send(c, answer.data(), answer.size(), MSG_NOSIGNAL);
  }

  int drips_;
  milliseconds every_;
  int fd_ = -1, port_ = 0;
  std::atomic<int> connections_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// The final statuses reported by a sender, by verdict id, with when each came.
struct Statuses {
  std::mutex mu;
  std::vector<std::pair<std::int64_t, std::string>> got;
  std::vector<Clock::time_point> at;
  WebhookSender::StatusFn Fn() {
    return [this](AuditVerdictId id, const std::string& status, std::int64_t) {
      std::lock_guard lock(mu);
      got.emplace_back(id.value(), status);
      at.push_back(Clock::now());
    };
  }
  std::size_t Count() {
    std::lock_guard lock(mu);
    return got.size();
  }
  bool WaitFor(std::size_t n, milliseconds timeout) {
    const auto t0 = Clock::now();
    while (Count() < n && Clock::now() - t0 < timeout) std::this_thread::sleep_for(milliseconds(5));
    return Count() >= n;
  }
};

WebhookOptions Options(const std::string& url, milliseconds timeout) {
  WebhookOptions o;
  o.url = url;
  o.attempts = 1;
  o.timeout = timeout;
  o.allow_private = true;
  return o;
}

TEST(WebhookDeadline, ADrippingReceiverEndsTheAttemptAtItsDeadlineAndTheNextVerdictGoesOut) {
  DripReceiver receiver(1, milliseconds(200));  // 47 bytes: ~9 s for the whole answer
  Statuses statuses;
  WebhookSender sender(Options(receiver.url(), milliseconds(1000)), statuses.Fn());
  const auto t0 = Clock::now();
  sender.Start();
  sender.Enqueue(AuditVerdictId(1), "{}");
  sender.Enqueue(AuditVerdictId(2), "{}");
  ASSERT_TRUE(statuses.WaitFor(2, milliseconds(5000)));
  EXPECT_EQ(statuses.got[0], (std::pair<std::int64_t, std::string>{1, "failed"}));
  EXPECT_EQ(statuses.got[1], (std::pair<std::int64_t, std::string>{2, "delivered"}));
  const auto first = statuses.at[0] - t0;
  EXPECT_GE(first, milliseconds(950));
  EXPECT_LT(first, milliseconds(3000));  // the whole answer would take ~9 s
  sender.Stop();
}

TEST(WebhookDeadline, AStopDuringADrippingAttemptIsPromptAndLeavesTheVerdictPending) {
  DripReceiver receiver(1, milliseconds(500));
  Statuses statuses;
  WebhookSender sender(Options(receiver.url(), milliseconds(60'000)), statuses.Fn());
  sender.Start();
  sender.Enqueue(AuditVerdictId(1), "{}");
  for (auto t = Clock::now(); receiver.connections() == 0 && Clock::now() - t < milliseconds(5000);)
    std::this_thread::sleep_for(milliseconds(5));
  std::this_thread::sleep_for(milliseconds(300));  // the answer has begun to drip
  const auto t0 = Clock::now();
  sender.Stop();
  EXPECT_LT(Clock::now() - t0, milliseconds(1000));  // not the attempt's 60 s
  EXPECT_EQ(statuses.Count(), 0u);                   // no status: the verdict stays "pending"
}

TEST(WebhookTargets, NamesResolvedToLoopbackAreRefusedAtDeliveryUnlessAllowed) {
  DripReceiver receiver(0, milliseconds(0));
  for (const std::string host : {"localhost", "127.1"}) {
    Statuses statuses;
    auto o = Options("http://" + host + ":" + std::to_string(receiver.port()) + "/hook",
                     milliseconds(2000));
    o.allow_private = false;
    WebhookSender sender(o, statuses.Fn());
    sender.Start();
    sender.Enqueue(AuditVerdictId(1), "{}");
    ASSERT_TRUE(statuses.WaitFor(1, milliseconds(3000))) << host;
    EXPECT_EQ(statuses.got[0].second, "failed") << host;
    EXPECT_EQ(receiver.connections(), 0) << host;
  }
  Statuses statuses;
  WebhookSender allowed(
      Options("http://127.1:" + std::to_string(receiver.port()) + "/hook", milliseconds(2000)),
      statuses.Fn());
  allowed.Start();
  allowed.Enqueue(AuditVerdictId(1), "{}");
  ASSERT_TRUE(statuses.WaitFor(1, milliseconds(3000)));
  EXPECT_EQ(statuses.got[0].second, "delivered");
}

TEST(WebhookTargets, PrivateAndLoopbackRanges) {
  for (const char* a : {"127.0.0.1", "127.255.0.9", "10.1.2.3", "172.16.0.1", "172.31.255.255",
                        "192.168.1.1", "169.254.169.254", "0.0.0.0", "100.64.0.1", "224.0.0.1",
                        "255.255.255.255", "::1", "::", "fc00::1", "fd12:3456::1", "fe80::1",
                        "ff02::1", "::ffff:127.0.0.1", "::ffff:10.0.0.1"}) {
    EXPECT_TRUE(IsPrivateAddress(*ParseIpAddress(a))) << a;
  }
  for (const char* a : {"8.8.8.8", "172.15.255.255", "172.32.0.1", "192.169.0.1", "100.128.0.1",
                        "2606:4700::1111", "::ffff:8.8.8.8"}) {
    EXPECT_FALSE(IsPrivateAddress(*ParseIpAddress(a))) << a;
  }
}

std::string Refusal(const std::string& url, bool allow) {
  try {
    CheckWebhookTarget(url, allow, "", "audit_webhook_url");
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "audit_webhook_url");
    return e.reason();
  }
  return "accepted";
}

TEST(WebhookTargets, LoopbackAndPrivateUrlsAreRefusedAtConfigurationUnlessAllowed) {
  for (const char* url : {"http://127.0.0.1:9000/hook", "http://localhost/x", "http://[::1]:8080/",
                          "http://10.0.0.5/x", "http://[::ffff:192.168.1.1]/x", "http://0.0.0.0"}) {
    EXPECT_NE(Refusal(url, false).find("audit_webhook_allow_private"), std::string::npos) << url;
    EXPECT_EQ(Refusal(url, true), "accepted") << url;
  }
  // A name is checked when it is resolved, at delivery.
  EXPECT_EQ(Refusal("http://hooks.example/x", false), "accepted");
  EXPECT_EQ(Refusal("http://93.184.215.14:8080/x", false), "accepted");
  EXPECT_EQ(Refusal("http://[2606:4700::1111]:8080/x", false), "accepted");
  EXPECT_NE(Refusal("http://[::1/x", true), "accepted");
  EXPECT_NE(Refusal("http://[::1]x/", true), "accepted");
}

class WebhookConfig : public TempDirTest {
 protected:
  std::string Write(const std::string& text) {
    std::ofstream(Path("k.json")) << text;
    return Path("k.json");
  }
};

TEST_F(WebhookConfig, TheRefusalNamesTheFileAndKeyOrTheOption) {
  const std::string url = R"("audit_webhook_url": "http://127.0.0.1:9000/hook")";
  try {
    ParseServerArgs({"--config", Write("{" + url + "}")});
    ADD_FAILURE() << "a loopback webhook was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), Path("k.json"));
    EXPECT_EQ(e.field(), "audit_webhook_url");
  }
  const auto file = Write("{" + url + R"(, "audit_webhook_allow_private": true})");
  EXPECT_TRUE(ParseServerArgs({"--config", file}).audit_webhook_allow_private);
  EXPECT_NO_THROW(
      ParseServerArgs({"--config", Write("{" + url + "}"), "--audit-webhook-allow-private"}));
  try {
    ParseServerArgs({"--audit-webhook-url", "http://192.168.0.7/hook"});
    ADD_FAILURE() << "a private webhook was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "");
    EXPECT_EQ(e.field(), "--audit-webhook-url");
  }
}

}  // namespace
}  // namespace km::server::test
