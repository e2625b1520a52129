#include "server/audits/webhook_client.h"

#include <netdb.h>
#include <sys/socket.h>

#include <atomic>
#include <cstring>
#include <future>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include "server/base/net_ranges.h"

namespace km::server {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

// How often a wait for a name's resolution looks at the deadline and at Abort().
constexpr std::chrono::milliseconds kResolvePoll{20};

struct Resolved {
  std::vector<tcp::endpoint> endpoints;
  std::string error;
};

Resolved ResolveNow(const std::string& host, int port) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* list = nullptr;
  const int rc = ::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &list);
  if (rc != 0) return {{}, "cannot resolve " + host + ": " + ::gai_strerror(rc)};
  Resolved out;
  for (const addrinfo* p = list; p != nullptr; p = p->ai_next) {
    tcp::endpoint e;
    if (p->ai_addrlen > e.capacity()) continue;
    std::memcpy(e.data(), p->ai_addr, p->ai_addrlen);
    e.resize(p->ai_addrlen);
    out.endpoints.push_back(e);
  }
  ::freeaddrinfo(list);
  return out;
}

// getaddrinfo cannot be interrupted: it runs on a thread of its own, left to finish alone
// when the deadline passes or the client is aborted first.
Resolved ResolveWithin(const WebhookTarget& t, WebhookClient::Clock::time_point deadline,
                       const std::atomic<bool>& aborted) {
  std::packaged_task<Resolved()> task(
      [host = t.host, port = t.port] { return ResolveNow(host, port); });
  auto result = task.get_future();
  std::thread(std::move(task)).detach();
  while (result.wait_for(kResolvePoll) != std::future_status::ready) {
    if (aborted) return {{}, "stopped"};
    if (WebhookClient::Clock::now() >= deadline)
      return {{}, "no address for " + t.host + " in time"};
  }
  return result.get();
}

IpAddress AddressOf(const tcp::endpoint& e) {
  IpAddress a;
  if (e.address().is_v4()) {
    const auto b = e.address().to_v4().to_bytes();
    std::memcpy(a.bytes.data(), b.data(), b.size());
  } else {
    a.v6 = true;
    const auto b = e.address().to_v6().to_bytes();
    std::memcpy(a.bytes.data(), b.data(), b.size());
  }
  return a;
}

// The endpoints a delivery may go to; an error naming the refused addresses when none is left.
Resolved Allowed(Resolved r, const std::string& host, bool allow_private) {
  if (allow_private || !r.error.empty()) return r;
  Resolved out;
  std::string refused;
  for (const auto& e : r.endpoints) {
    if (!IsPrivateAddress(AddressOf(e))) {
      out.endpoints.push_back(e);
    } else if (refused.size() < 200) {
      refused += (refused.empty() ? "" : ", ") + e.address().to_string();
    }
  }
  if (out.endpoints.empty()) {
    out.error = host + " is a loopback or private address (" + refused +
                "); audit_webhook_allow_private allows it";
  }
  return out;
}

std::string HostHeader(const WebhookTarget& t) {
  const bool v6 = t.host.find(':') != std::string::npos;
  const std::string host = v6 ? "[" + t.host + "]" : t.host;
  return t.port == 80 ? host : host + ":" + std::to_string(t.port);
}

http::request<http::string_body> Request(const WebhookTarget& t,
                                         const WebhookClient::Headers& headers,
                                         const std::string& body) {
  http::request<http::string_body> req{http::verb::post, t.path, 11};
  req.set(http::field::host, HostHeader(t));
  req.set(http::field::user_agent, "kinemetricd");
  req.set(http::field::content_type, "application/json");
  req.set(http::field::connection, "close");
  for (const auto& [k, v] : headers) req.set(k, v);
  req.body() = body;
  req.prepare_payload();
  return req;
}

// One exchange on the client's io_context: connect, send, read the answer's header.
struct Exchange {
  Exchange(beast::tcp_stream& s, http::request<http::string_body> r)
      : stream(s), request(std::move(r)) {}

  beast::tcp_stream& stream;
  http::request<http::string_body> request;
  beast::flat_buffer buffer;
  http::response_parser<http::empty_body> parser;
  WebhookPostResult result;

  void Fail(const char* step, const beast::error_code& ec) {
    result.error = ec == beast::error::timeout ? std::string("no answer in time (") + step + ")"
                                               : std::string(step) + ": " + ec.message();
  }

  void Start(const std::vector<tcp::endpoint>& endpoints) {
    stream.async_connect(endpoints, [this](beast::error_code ec, const tcp::endpoint&) {
      if (ec) return Fail("connecting", ec);
      http::async_write(stream, request, [this](beast::error_code ec, std::size_t) {
        if (ec) return Fail("sending", ec);
        http::async_read_header(stream, buffer, parser, [this](beast::error_code ec, std::size_t) {
          if (ec) return Fail("reading the answer", ec);
          result.status = static_cast<int>(parser.get().result_int());
        });
      });
    });
  }
};

}  // namespace

struct WebhookClient::Impl {
  asio::io_context ioc;
  std::atomic<bool> aborted{false};
  beast::tcp_stream* current = nullptr;  // the attempt under way; used on ioc's thread only
};

WebhookClient::WebhookClient() : impl_(std::make_unique<Impl>()) {}

WebhookClient::~WebhookClient() = default;

WebhookPostResult WebhookClient::Post(const WebhookTarget& target, const Headers& headers,
                                      const std::string& body, Clock::time_point deadline,
                                      bool allow_private) {
  const Resolved to =
      Allowed(ResolveWithin(target, deadline, impl_->aborted), target.host, allow_private);
  if (impl_->aborted) return {0, "stopped", true};
  if (!to.error.empty()) return {0, to.error, false};
  beast::tcp_stream stream(impl_->ioc);
  stream.expires_at(deadline);  // one expiry for the connection, the request and the answer
  Exchange x(stream, Request(target, headers, body));
  impl_->current = &stream;
  x.Start(to.endpoints);
  impl_->ioc.restart();
  impl_->ioc.run();
  impl_->current = nullptr;
  if (impl_->aborted) return {0, "stopped", true};
  return x.result;
}

void WebhookClient::Abort() {
  impl_->aborted = true;
  asio::post(impl_->ioc, [impl = impl_.get()] {
    if (impl->current != nullptr) impl->current->close();
  });
}

}  // namespace km::server
