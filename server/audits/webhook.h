// Delivery of accuracy-audit verdicts to a webhook (config audit_webhook_url): a background
// queue, off the request path. Each verdict is POSTed as JSON; a failure (no connection, no
// whole answer within the timeout, a status other than 2xx, a target that is not a public
// address) is retried after 1 s, 2 s, 4 s, … (first_delay doubled) up to `attempts` attempts in
// all. The timeout bounds the whole attempt (server/audits/webhook_client.h). Stop() aborts the
// attempt under way at once: verdicts not yet delivered stay "pending" (AuditScheduler::Start
// sends them again).
//
// Delivery is at least once: every POST carries X-Kinemetric-Delivery ("audit-<id>", the same
// for every attempt and every instance, for the receiver to drop repeats), X-Kinemetric-Attempt
// and X-Kinemetric-Timestamp (Unix seconds), and with a secret X-Kinemetric-Signature:
// "sha256=" + hex HMAC-SHA256(secret, timestamp + "." + body).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "server/audits/webhook_client.h"
#include "server/base/ids.h"

namespace km::server {

struct WebhookOptions {
  std::string url;  // "http://HOST[:PORT][/PATH]"
  int attempts = 5;
  std::chrono::milliseconds first_delay{1000};
  std::chrono::milliseconds timeout{5000};  // the whole of one attempt
  std::string secret;                       // key of X-Kinemetric-Signature; empty: unsigned
  // Deliveries to loopback and private addresses (net_ranges.h IsPrivateAddress); refused
  // unless allowed.
  bool allow_private = false;
};

// The headers of one delivery attempt of verdict `id` sent at Unix time `unix_s`.
std::vector<std::pair<std::string, std::string>> WebhookHeaders(const WebhookOptions& options,
                                                                AuditVerdictId id, int attempt,
                                                                std::int64_t unix_s,
                                                                const std::string& body);

class WebhookSender {
 public:
  // status(id, "delivered" | "failed" | "pending", attempts so far) after every attempt.
  using StatusFn = std::function<void(AuditVerdictId, const std::string&, std::int64_t)>;
  WebhookSender(WebhookOptions options, StatusFn status);
  ~WebhookSender();
  WebhookSender(const WebhookSender&) = delete;
  WebhookSender& operator=(const WebhookSender&) = delete;

  void Start();
  // Ends the queue, aborting the attempt under way (prompt: no wait for the receiver).
  void Stop();
  void Enqueue(AuditVerdictId id, std::string body);

 private:
  struct Item {
    AuditVerdictId id;
    std::string body;
  };
  enum class Outcome { kDelivered, kFailed, kStopped };
  void Loop();
  // Every attempt of one verdict, with the waits between them; false when stopped.
  bool Send(const Item& item, std::unique_lock<std::mutex>& lock);
  Outcome Deliver(const Item& item, int attempt);

  WebhookOptions options_;
  StatusFn status_;
  WebhookTarget target_;
  WebhookClient client_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Item> queue_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace km::server
