#include "server/audits/webhook.h"

#include <charconv>
#include <iostream>

#include "analysis/core/errors.h"
#include "server/base/sha256.h"

namespace km::server {

std::vector<std::pair<std::string, std::string>> WebhookHeaders(const WebhookOptions& options,
                                                                AuditVerdictId id, int attempt,
                                                                std::int64_t unix_s,
                                                                const std::string& body) {
  const std::string ts = std::to_string(unix_s);
  std::vector<std::pair<std::string, std::string>> h{
      {"X-Kinemetric-Delivery", "audit-" + to_string(id)},
      {"X-Kinemetric-Attempt", std::to_string(attempt)},
      {"X-Kinemetric-Timestamp", ts}};
  if (!options.secret.empty()) {
    h.emplace_back("X-Kinemetric-Signature",
                   "sha256=" + HmacSha256Hex(options.secret, ts + "." + body));
  }
  return h;
}

WebhookSender::WebhookSender(WebhookOptions options, StatusFn status)
    : options_(std::move(options)),
      status_(std::move(status)),
      target_(ParseWebhookUrl(options_.url, "audit_webhook_url")) {}

WebhookSender::~WebhookSender() {
  Stop();
}

void WebhookSender::Start() {
  std::lock_guard lock(mu_);
  if (thread_.joinable() || stop_) return;
  thread_ = std::thread([this] { Loop(); });
}

void WebhookSender::Stop() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  client_.Abort();
  if (thread_.joinable()) thread_.join();
}

void WebhookSender::Enqueue(AuditVerdictId id, std::string body) {
  {
    std::lock_guard lock(mu_);
    queue_.push_back({id, std::move(body)});
  }
  cv_.notify_all();
}

WebhookSender::Outcome WebhookSender::Deliver(const Item& item, int attempt) {
  const auto unix_s = std::chrono::duration_cast<std::chrono::seconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  const auto deadline = WebhookClient::Clock::now() + options_.timeout;
  const auto res =
      client_.Post(target_, WebhookHeaders(options_, item.id, attempt, unix_s, item.body),
                   item.body, deadline, options_.allow_private);
  if (res.aborted) return Outcome::kStopped;
  if (res.status >= 200 && res.status < 300) return Outcome::kDelivered;
  std::cerr << "kinemetricd: audit " << item.id << " webhook attempt " << attempt << " of "
            << options_.attempts << ": "
            << (res.status != 0 ? "answered " + std::to_string(res.status) : res.error)
            << std::endl;
  return Outcome::kFailed;
}

bool WebhookSender::Send(const Item& item, std::unique_lock<std::mutex>& lock) {
  auto delay = options_.first_delay;
  for (int attempt = 1; attempt <= options_.attempts; ++attempt) {
    lock.unlock();
    const Outcome outcome = Deliver(item, attempt);
    if (outcome == Outcome::kStopped) {
      lock.lock();
      return false;  // stays "pending", sent again at the next start
    }
    const bool ok = outcome == Outcome::kDelivered;
    const bool last = ok || attempt == options_.attempts;
    status_(item.id, ok ? "delivered" : last ? "failed" : "pending", attempt);
    lock.lock();
    if (last) return true;
    if (cv_.wait_for(lock, delay, [this] { return stop_; })) return false;
    delay *= 2;
  }
  return true;
}

void WebhookSender::Loop() {
  std::unique_lock lock(mu_);
  while (true) {
    cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    const Item item = std::move(queue_.front());
    queue_.pop_front();
    if (!Send(item, lock)) return;
  }
}

}  // namespace km::server
