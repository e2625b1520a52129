#include "server/base/webhook_url.h"

#include <charconv>

#include "analysis/core/errors.h"
#include "server/base/net_ranges.h"

namespace km::server {
namespace {

std::string Quoted(const std::string& url) {
  return "'" + url.substr(0, 80) + "'";
}

// "HOST[:PORT]" or "[IPV6][:PORT]" of an http:// URL.
void ParseAuthority(const std::string& authority, const std::string& url, const std::string& field,
                    WebhookTarget& out) {
  std::string port;
  bool has_port = false;
  if (!authority.empty() && authority.front() == '[') {
    const auto close = authority.find(']');
    if (close == std::string::npos) throw InvalidInput("", 0, field, Quoted(url) + " has no host");
    out.host = authority.substr(1, close - 1);
    const std::string rest = authority.substr(close + 1);
    if (!rest.empty() && rest.front() != ':') {
      throw InvalidInput("", 0, field, Quoted(url) + " has no valid port");
    }
    has_port = !rest.empty();
    if (has_port) port = rest.substr(1);
  } else {
    const auto colon = authority.rfind(':');
    out.host = authority.substr(0, colon);
    has_port = colon != std::string::npos;
    if (has_port) port = authority.substr(colon + 1);
  }
  if (has_port) {
    const auto [ptr, ec] = std::from_chars(port.data(), port.data() + port.size(), out.port);
    if (ec != std::errc() || ptr != port.data() + port.size() || out.port < 1 || out.port > 65535) {
      throw InvalidInput("", 0, field, Quoted(url) + " has no valid port");
    }
  }
  if (out.host.empty()) throw InvalidInput("", 0, field, Quoted(url) + " has no host");
}

}  // namespace

WebhookTarget ParseWebhookUrl(const std::string& url, const std::string& field) {
  const std::string scheme = "http://";
  if (url.rfind(scheme, 0) != 0 || url.size() > 2048) {
    throw InvalidInput("", 0, field, Quoted(url) + " is not an http:// URL");
  }
  for (const char c : url) {
    if (static_cast<unsigned char>(c) <= 0x20 || c == 0x7F) {
      throw InvalidInput("", 0, field, Quoted(url) + " has a space or a control character");
    }
  }
  const std::string rest = url.substr(scheme.size());
  const auto slash = rest.find('/');
  WebhookTarget out;
  out.path = slash == std::string::npos ? "/" : rest.substr(slash);
  ParseAuthority(rest.substr(0, slash), url, field, out);
  return out;
}

void CheckWebhookUrl(const std::string& url, const std::string& field) {
  ParseWebhookUrl(url, field);
}

void CheckWebhookTarget(const std::string& url, bool allow_private, const std::string& file,
                        const std::string& field) {
  const WebhookTarget t = ParseWebhookUrl(url, field);
  const auto address = ParseIpAddress(t.host);
  if (allow_private || !address || !IsPrivateAddress(*address)) return;
  throw InvalidInput(file, 0, field,
                     Quoted(url) +
                         " is a loopback or private address; webhooks go there only with "
                         "audit_webhook_allow_private: true in the config file "
                         "(--audit-webhook-allow-private)");
}

void CheckWebhookSecret(const std::string& secret, const std::string& field) {
  if (secret.size() < 16 || secret.size() > 1024) {
    throw InvalidInput("", 0, field,
                       "a webhook secret must have 16 to 1024 bytes (it has " +
                           std::to_string(secret.size()) + ")");
  }
}

}  // namespace km::server
