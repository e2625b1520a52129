// One HTTP/1.1 POST of an audit webhook (server/audits/webhook.h) under one deadline for the whole
// attempt: name resolution, connection, request and the answer's header together, so a
// receiver that answers a byte at a time cannot hold it longer. Only to public addresses
// unless private ones are allowed: the names are resolved here and the connection goes to the
// addresses checked, never to a second resolution. Abort() (from any thread) ends an attempt
// under way at once, for a prompt stop of the server.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "server/base/webhook_url.h"

namespace km::server {

struct WebhookPostResult {
  int status = 0;        // the answer's HTTP status; 0: no answer (see error)
  std::string error;     // why there is no answer
  bool aborted = false;  // ended by Abort()
};

class WebhookClient {
 public:
  using Headers = std::vector<std::pair<std::string, std::string>>;
  using Clock = std::chrono::steady_clock;

  WebhookClient();
  ~WebhookClient();
  WebhookClient(const WebhookClient&) = delete;
  WebhookClient& operator=(const WebhookClient&) = delete;

  // POSTs `body` (application/json) with `headers`, all of it before `deadline`. Addresses that
  // are not public (net_ranges.h IsPrivateAddress) are skipped unless `allow_private`; a host
  // with no other address is an error without a connection. Not for several threads at once.
  WebhookPostResult Post(const WebhookTarget& target, const Headers& headers,
                         const std::string& body, Clock::time_point deadline, bool allow_private);
  // Ends the Post under way, if any, and makes every later one return aborted at once.
  void Abort();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace km::server
