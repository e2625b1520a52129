#include "server/webhook.h"

#include <charconv>
#include <iostream>

#include <httplib.h>

#include "analysis/core/errors.h"
#include "server/sha256.h"

namespace km::server {
namespace {

struct Url {
  std::string host, path;
  int port = 80;
};

Url ParseUrl(const std::string& url, const std::string& field) {
  const std::string scheme = "http://";
  if (url.rfind(scheme, 0) != 0 || url.size() > 2048) {
    throw InvalidInput("", 0, field, "'" + url.substr(0, 80) + "' is not an http:// URL");
  }
  const std::string rest = url.substr(scheme.size());
  const auto slash = rest.find('/');
  const std::string authority = rest.substr(0, slash);
  Url out;
  out.path = slash == std::string::npos ? "/" : rest.substr(slash);
  const auto colon = authority.rfind(':');
  out.host = authority.substr(0, colon);
  if (colon != std::string::npos) {
    const std::string port = authority.substr(colon + 1);
    const auto [ptr, ec] = std::from_chars(port.data(), port.data() + port.size(), out.port);
    if (ec != std::errc() || ptr != port.data() + port.size() || out.port < 1 || out.port > 65535) {
      throw InvalidInput("", 0, field, "'" + url.substr(0, 80) + "' has no valid port");
    }
  }
  if (out.host.empty()) throw InvalidInput("", 0, field, "'" + url.substr(0, 80) + "' has no host");
  return out;
}

}  // namespace

void CheckWebhookUrl(const std::string& url, const std::string& field) {
  ParseUrl(url, field);
}

void CheckWebhookSecret(const std::string& secret, const std::string& field) {
  if (secret.size() < 16 || secret.size() > 1024) {
    throw InvalidInput("", 0, field,
                       "a webhook secret must have 16 to 1024 bytes (it has " +
                           std::to_string(secret.size()) + ")");
  }
}

std::vector<std::pair<std::string, std::string>> WebhookHeaders(const WebhookOptions& options,
                                                                std::int64_t id, int attempt,
                                                                std::int64_t unix_s,
                                                                const std::string& body) {
  const std::string ts = std::to_string(unix_s);
  std::vector<std::pair<std::string, std::string>> h{
      {"X-Kinemetric-Delivery", "audit-" + std::to_string(id)},
      {"X-Kinemetric-Attempt", std::to_string(attempt)},
      {"X-Kinemetric-Timestamp", ts}};
  if (!options.secret.empty()) {
    h.emplace_back("X-Kinemetric-Signature",
                   "sha256=" + HmacSha256Hex(options.secret, ts + "." + body));
  }
  return h;
}

WebhookSender::WebhookSender(WebhookOptions options, StatusFn status)
    : options_(std::move(options)), status_(std::move(status)) {
  const Url u = ParseUrl(options_.url, "audit_webhook_url");
  host_ = u.host;
  path_ = u.path;
  port_ = u.port;
}

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
  if (thread_.joinable()) thread_.join();
}

void WebhookSender::Enqueue(std::int64_t id, std::string body) {
  {
    std::lock_guard lock(mu_);
    queue_.push_back({id, std::move(body)});
  }
  cv_.notify_all();
}

bool WebhookSender::Deliver(const Item& item, int attempt) {
  const auto unix_s = std::chrono::duration_cast<std::chrono::seconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  httplib::Headers headers;
  for (auto& [k, v] : WebhookHeaders(options_, item.id, attempt, unix_s, item.body))
    headers.emplace(k, v);
  httplib::Client client(host_, port_);
  const auto t = static_cast<time_t>(options_.timeout.count());
  client.set_connection_timeout(t, 0);
  client.set_read_timeout(t, 0);
  client.set_write_timeout(t, 0);
  const auto res = client.Post(path_, headers, item.body, "application/json");
  return res && res->status >= 200 && res->status < 300;
}

void WebhookSender::Loop() {
  std::unique_lock lock(mu_);
  while (true) {
    cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    const Item item = std::move(queue_.front());
    queue_.pop_front();
    auto delay = options_.first_delay;
    for (int attempt = 1; attempt <= options_.attempts; ++attempt) {
      lock.unlock();
      const bool ok = Deliver(item, attempt);
      const bool last = ok || attempt == options_.attempts;
      status_(item.id, ok ? "delivered" : last ? "failed" : "pending", attempt);
      lock.lock();
      if (last) break;
      if (cv_.wait_for(lock, delay, [this] { return stop_; })) return;
      delay *= 2;
    }
  }
}

}  // namespace km::server
