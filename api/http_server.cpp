#include "api/http_server.h"

#include <sys/resource.h>
#include <sys/socket.h>

#include <chrono>
#include <random>
#include <thread>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

#include "analysis/core/errors.h"
#include "api/http_session.h"

namespace km::api {
namespace {

namespace net = boost::asio;
using tcp = net::ip::tcp;

// Each connection is a descriptor: allow as many as the hard limit permits.
void RaiseDescriptorLimit(std::size_t wanted) {
  rlimit lim{};
  if (getrlimit(RLIMIT_NOFILE, &lim) != 0) return;
  const rlim_t want = static_cast<rlim_t>(wanted) + 256;
  if (lim.rlim_cur >= want) return;
  lim.rlim_cur = lim.rlim_max == RLIM_INFINITY ? want : std::min(want, lim.rlim_max);
  setrlimit(RLIMIT_NOFILE, &lim);
}

std::string RandomPrefix() {
  std::random_device rd;
  char buf[16];
  std::snprintf(buf, sizeof buf, "%08x", rd());
  return buf;
}

// Over the connection cap: one short answer, written without waiting, then the socket closes.
void RefuseConnection(tcp::socket& socket) {
  static const std::string kBusy = [] {
    const std::string body =
        Problem(503, "Service Unavailable", "too many connections; retry shortly").body;
    return "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/problem+json\r\n"
           "Retry-After: 1\r\nConnection: close\r\nContent-Length: " +
           std::to_string(body.size()) + "\r\n\r\n" + body;
  }();
  ::send(socket.native_handle(), kBusy.data(), kBusy.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  boost::system::error_code ignored;
  socket.close(ignored);
}

}  // namespace

struct HttpServer::Impl {
  Impl(const Router& router, HttpOptions options)
      : ctx(router, std::move(options)), acceptor(ioc), retry(ioc) {
    ctx.request_id_prefix = RandomPrefix();
  }
  ~Impl() { StopAll(); }

  void Accept() {
    acceptor.async_accept(net::make_strand(ioc),
                          [this](boost::system::error_code ec, tcp::socket socket) {
                            OnAccept(ec, std::move(socket));
                          });
  }

  void OnAccept(boost::system::error_code ec, tcp::socket socket) {
    if (ec == net::error::operation_aborted || !acceptor.is_open()) return;
    if (ec) {
      // Out of descriptors or memory: pause accepting briefly instead of spinning.
      retry.expires_after(std::chrono::milliseconds(50));
      retry.async_wait([this](boost::system::error_code wait_ec) {
        if (!wait_ec) Accept();
      });
      return;
    }
    boost::system::error_code opt_ec;
    socket.set_option(tcp::no_delay(true), opt_ec);
    boost::system::error_code ep_ec;
    const auto ep = socket.remote_endpoint(ep_ec);
    std::string address = ep_ec ? std::string() : ep.address().to_string();
    if (ctx.registry.Admit(address, ctx.options.max_connections,
                           ctx.options.max_connections_per_client)) {
      StartSession(std::move(socket), std::move(address), ctx);
    } else {
      RefuseConnection(socket);
    }
    Accept();
  }

  void StopAll() {
    net::post(ioc, [this] {
      boost::system::error_code ignored;
      acceptor.close(ignored);
      retry.cancel();
    });
    ioc.stop();
    ctx.pool.Stop();
  }

  ServerContext ctx;  // outlives the event loop: sessions count themselves out of it
  net::io_context ioc;
  tcp::acceptor acceptor;
  net::steady_timer retry;
};

HttpServer::HttpServer(const Router& router, HttpOptions options) {
  if (options.threads < 1 || options.io_threads < 1 || options.queue_limit < 1 ||
      options.max_connections < 1 || options.max_connections_per_client < 1) {
    throw InvalidInput("", 0, "threads",
                       "threads, io_threads, queue_limit, max_connections and "
                       "max_connections_per_client must be at least 1");
  }
  impl_ = std::make_unique<Impl>(router, std::move(options));
}

HttpServer::~HttpServer() {
  Stop();
}

int HttpServer::Bind() {
  auto& a = impl_->acceptor;
  const auto& o = impl_->ctx.options;
  RaiseDescriptorLimit(o.max_connections);
  boost::system::error_code ec;
  const auto address = net::ip::make_address(o.host, ec);
  if (ec) throw Error("cannot bind: '" + o.host + "' is not an IP address");
  const tcp::endpoint endpoint(address, static_cast<unsigned short>(o.port));
  a.open(endpoint.protocol(), ec);
  if (!ec) a.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) a.bind(endpoint, ec);
  if (!ec) a.listen(o.backlog, ec);
  if (ec) {
    throw Error("cannot bind to " + o.host + ":" + std::to_string(o.port) + " (" + ec.message() +
                "; is another server running there?)");
  }
  return a.local_endpoint().port();
}

void HttpServer::Serve() {
  // Keeps the loop running while every request is on a worker and the acceptor is closed (a
  // graceful stop); Stop() ends it.
  const auto work = net::make_work_guard(impl_->ioc);
  impl_->Accept();
  std::vector<std::thread> extra;
  for (int i = 1; i < impl_->ctx.options.io_threads; ++i) {
    extra.emplace_back([this] { impl_->ioc.run(); });
  }
  impl_->ioc.run();
  for (auto& t : extra) t.join();
}

void HttpServer::Stop() {
  if (impl_) impl_->StopAll();
}

std::int64_t HttpServer::Shutdown(std::chrono::milliseconds grace) {
  auto& ctx = impl_->ctx;
  ctx.stopping = true;
  net::post(impl_->ioc, [this] {
    boost::system::error_code ignored;
    impl_->acceptor.close(ignored);
    impl_->retry.cancel();
  });
  const auto deadline = std::chrono::steady_clock::now() + grace;
  while (ctx.in_flight.load() > 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const std::int64_t left = ctx.in_flight.load();
  Stop();
  return left;
}

std::int64_t HttpServer::InFlight() const {
  return impl_->ctx.in_flight.load();
}

}  // namespace km::api
