// A webhook's address and secret as the configuration and the audits' delivery check them
// (server/audits/webhook.h sends): an http:// URL with a host and an optional port, a host that
// is not a loopback or private address unless allowed, a signing secret of 16–1024 bytes. Each
// check throws km::InvalidInput naming `field`.
#pragma once

#include <string>

namespace km::server {

struct WebhookTarget {
  std::string host;  // a name or a numeric address (IPv6 without brackets)
  int port = 80;
  std::string path = "/";
};

// The parts of an http:// URL (at most 2048 bytes, no space or control character).
WebhookTarget ParseWebhookUrl(const std::string& url, const std::string& field);
// Checks a webhook URL (http:// only); km::InvalidInput naming `field` when it is not one.
void CheckWebhookUrl(const std::string& url, const std::string& field);
// Checks that a webhook URL's host is not a loopback or private address written as such
// (127.0.0.1, [::1], localhost, 10.1.2.3, …) unless `allow_private`; km::InvalidInput naming
// `field` (in `file`, when not empty) and the setting that allows it. A host name is checked
// when it is resolved, at every delivery.
void CheckWebhookTarget(const std::string& url, bool allow_private, const std::string& file,
                        const std::string& field);
// Checks a webhook signing secret (16–1024 bytes); km::InvalidInput naming `field` otherwise.
void CheckWebhookSecret(const std::string& secret, const std::string& field);

}  // namespace km::server
