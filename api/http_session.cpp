#include "api/http_session.h"

#include <array>
#include <chrono>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include "api/http_framing.h"
#include "api/http_target.h"
#include "api/metrics.h"

namespace km::api {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using std::chrono::seconds;

constexpr const char* kApiCsp = "default-src 'none'; frame-ancestors 'none'";
constexpr const char* kPageCsp =
    "default-src 'self'; img-src 'self' blob: data:; object-src 'none'; base-uri 'none'; "
    "frame-ancestors 'none'; form-action 'self'";
constexpr std::size_t kStreamPieceBytes = 64u << 10;
// The status recorded (access log, audit log, metrics) for a request whose client closed the
// connection before its body ended; never sent (as in nginx).
constexpr int kClientClosedRequest = 499;
constexpr std::size_t kMaxDrainBytes = 1u << 20;
// "No limit" for Beast's parser. Not boost::none: Boost 1.74 compares lengths against an empty
// optional as if it were smaller than any value and refuses every body.
constexpr std::uint64_t kUnlimited = std::numeric_limits<std::uint64_t>::max();

bool IsStaticPath(const std::string& path) {
  return path == "/" || path.rfind("/static/", 0) == 0;
}

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket&& socket, const std::string& address, ServerContext& ctx)
      : stream_(std::move(socket)),
        ctx_(ctx),
        remote_addr_(address),
        registry_id_(ctx.registry.Open(address)) {
    ++ctx_.connections;
  }
  ~Session() {
    EndRequest();
    ctx_.registry.Close(registry_id_);
    --ctx_.connections;
  }

  void Start() {
    net::dispatch(stream_.get_executor(), [self = shared_from_this()] { self->ReadHeader(); });
  }

 private:
  // ---- request line and headers -------------------------------------------------------------
  void ReadHeader() {
    has_body_ = head_ = false;
    header_.emplace();
    header_->header_limit(static_cast<std::uint32_t>(ctx_.options.max_header_bytes));
    header_->body_limit(kUnlimited);
    const int wait =
        served_ == 0 ? ctx_.options.header_timeout_s : ctx_.options.keep_alive_timeout_s;
    stream_.expires_after(seconds(wait));
    waiting_ = true;
    ctx_.registry.Waiting(registry_id_, [weak = weak_from_this()] {
      if (const auto self = weak.lock()) {
        net::post(self->stream_.get_executor(), [self] { self->Evict(); });
      }
    });
    http::async_read_header(
        stream_, buffer_, *header_,
        [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnHeader(ec); });
  }

  // Another client needs this connection's place while it waits for headers (api/
  // connection_registry.h): closed without an answer, as after the header deadline.
  void Evict() {
    if (!waiting_) return;
    evicted_ = true;
    beast::error_code ignored;
    stream_.socket().cancel(ignored);
  }

  void OnHeader(beast::error_code ec) {
    waiting_ = false;
    ctx_.registry.Busy(registry_id_);
    if (evicted_) return Close();
    if (ec == http::error::end_of_stream || ec == beast::error::timeout ||
        ec == net::error::connection_reset || ec == net::error::eof) {
      return Close();
    }
    BeginRequest();
    if (ec == http::error::header_limit) {
      return Respond(Problem(431, "Request Header Fields Too Large",
                             "the request headers exceed " +
                                 std::to_string(ctx_.options.max_header_bytes) + " bytes"),
                     true);
    }
    if (ec) return Respond(Problem(400, "Bad Request", "the request is not valid HTTP/1.1"), true);
    const auto& msg = header_->get();
    req_.id = ctx_.NextRequestId();
    req_.method = std::string(msg.method_string());
    head_ = msg.method() == http::verb::head;
    if (head_) req_.method = "GET";
    req_.remote_addr = remote_addr_;  // known since the connection was accepted
    std::vector<std::pair<std::string, std::string>> fields;
    for (const auto& field : msg) {
      std::string name(field.name_string());
      for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      fields.emplace_back(name, std::string(field.value()));
      req_.headers[name] = std::string(field.value());
    }
    keep_alive_ = msg.keep_alive();
    has_body_ = header_->chunked() || header_->content_length().value_or(0) > 0;
    // A body whose length is in doubt is never read: answered, and the connection closed.
    if (const auto refusal = CheckFraming(fields, msg.version())) {
      has_body_ = false;
      const char* title = refusal->status == 501 ? "Not Implemented" : "Bad Request";
      return Respond(Problem(refusal->status, title, refusal->detail), true);
    }
    std::string error;
    auto target = ParseTarget(std::string_view(msg.target().data(), msg.target().size()), error);
    if (!target) return Respond(Problem(400, "Bad Request", error), true);
    req_.path = std::move(target->path);
    req_.query = std::move(target->query);
    if (ctx_.stopping.load()) {
      Response stopping = Problem(503, "Service Unavailable", "the server is stopping");
      stopping.headers["Retry-After"] = "1";
      return Respond(std::move(stopping), true);
    }
    if (req_.method == "OPTIONS" && req_.Header("origin")) return Respond(Preflight(), false);
    if (req_.method == "GET" && IsStaticPath(req_.path)) {
      req_.route = req_.path == "/" ? "/" : "/static/{file}";
      return Enqueue([self = shared_from_this()] {
        self->PostRespond(ServeStatic(self->ctx_.options.static_root, self->req_.path), false);
      });
    }
    Enqueue([self = shared_from_this()] { self->AdmitOnWorker(); });
  }

  // Runs on a worker: access from the headers, then the handler or the body.
  void AdmitOnWorker() {
    Response refusal;
    route_ = ctx_.router.Admit(req_, refusal);
    if (!route_) return PostRespond(std::move(refusal), false);
    if (!has_body_) return PostRespond(ctx_.router.Run(*route_, req_), false);
    if (route_->open_body) {
      try {
        sink_ = route_->open_body(req_);
      } catch (...) {
        return PostRespond(ErrorResponse(std::current_exception(), req_), true);
      }
      return Post([self = shared_from_this()] { self->StartStreamBody(); });
    }
    const auto length = header_->content_length();
    if (length && *length > BodyLimit()) return PostRespond(TooLargeProblem(), true);
    Post([self = shared_from_this()] { self->StartBody(); });
  }

  // ---- whole bodies -------------------------------------------------------------------------
  void StartBody() {
    body_.emplace(std::move(*header_));
    body_->body_limit(BodyLimit());
    SendContinueThen([self = shared_from_this()] { self->ReadBody(); });
  }

  void ReadBody() {
    stream_.expires_after(seconds(ctx_.options.read_timeout_s));
    http::async_read_some(
        stream_, buffer_, *body_,
        [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnBody(ec); });
  }

  void OnBody(beast::error_code ec) {
    if (ec == http::error::body_limit) {  // a chunked body over the limit: audited like others
      return Enqueue(
          [self = shared_from_this()] { self->PostRespond(self->TooLargeProblem(), true); }, true);
    }
    if (ec) {
      return Enqueue(
          [self = shared_from_this(), ec] {
            self->Abandon(ec, Problem(400, "Bad Request", "the body ended before it was complete"));
          },
          true);
    }
    if (!body_->is_done()) return ReadBody();
    req_.body = body_->release().body();
    Enqueue(
        [self = shared_from_this()] {
          try {
            self->RecheckAccess();  // the body may have taken long to arrive
          } catch (...) {
            return self->PostRespond(ErrorResponse(std::current_exception(), self->req_), false);
          }
          self->PostRespond(self->ctx_.router.Run(*self->route_, self->req_), false);
        },
        true);
  }

  // ---- streamed bodies: one piece at a time, fed on a worker, no thread waits ----------------
  void StartStreamBody() {
    stream_body_.emplace(std::move(*header_));
    stream_body_->body_limit(kUnlimited);
    piece_.resize(kStreamPieceBytes);
    SendContinueThen([self = shared_from_this()] { self->ReadPiece(); });
  }

  void ReadPiece() {
    auto& body = stream_body_->get().body();
    body.data = piece_.data();
    body.size = piece_.size();
    body.more = true;
    stream_.expires_after(seconds(ctx_.options.read_timeout_s));
    http::async_read_some(
        stream_, buffer_, *stream_body_,
        [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnPiece(ec); });
  }

  void OnPiece(beast::error_code ec) {
    if (ec == http::error::need_buffer) ec = {};
    if (ec) {
      // The client went away or stalled: keep what arrived, answer nobody.
      return Enqueue(
          [self = shared_from_this(), ec] {
            Response kept;
            try {
              kept = self->sink_->Finish(false);
            } catch (...) {
              kept = ErrorResponse(std::current_exception(), self->req_);
            }
            self->Abandon(ec, std::move(kept));
          },
          true);
    }
    const std::size_t got = piece_.size() - stream_body_->get().body().size;
    const bool done = stream_body_->is_done();
    Enqueue(
        [self = shared_from_this(), got, done] {
          try {
            self->RecheckAccess();
            if (got > 0) self->sink_->Feed(std::string_view(self->piece_.data(), got));
            if (done) return self->PostRespond(self->sink_->Finish(true), false);
          } catch (...) {
            return self->PostRespond(ErrorResponse(std::current_exception(), self->req_), true);
          }
          self->Post([self] { self->ReadPiece(); });
        },
        true);
  }

  // A streamed body may last for hours: its token is checked again before every piece is fed
  // (the token hook's cache makes that cheap; a revocation in this process empties the cache,
  // one on another instance is seen within the cache's 2 s), so a revoked or expired token
  // stops writing at once. What was fed before stays stored, as after a bad frame; the answer
  // is 401.
  void RecheckAccess() { ctx_.router.Recheck(req_, *route_); }

  // The client went away (499) or stalled past the read timeout (408) before its body ended. No
  // answer can be delivered, but the request still leaves its access-log line and, through the
  // observer, its audit entry (what a streamed body stored before is kept and counted in it).
  void Abandon(beast::error_code ec, Response res) {
    res.status = ec == beast::error::timeout ? 408 : kClientClosedRequest;
    ctx_.router.Observe(req_, route_, res);
    Record(res);
    Post([self = shared_from_this()] { self->Close(); });
  }

  // ---- CORS: only the configured origins ----------------------------------------------------
  bool OriginAllowed() const {
    const auto origin = req_.Header("origin");
    if (!origin) return false;
    for (const auto& o : ctx_.options.cors_origins) {
      if (o == *origin) return true;
    }
    return false;
  }

  // The answer to a browser's preflight request (OPTIONS with Origin).
  Response Preflight() const {
    if (!OriginAllowed()) {
      return Problem(403, "Forbidden",
                     "the origin '" + req_.Header("origin").value_or("") +
                         "' may not call this API from a browser (server option cors_origins)");
    }
    Response r;
    r.status = 204;
    r.content_type = "text/plain";
    r.headers["Access-Control-Allow-Methods"] = "GET, HEAD, POST, PUT, DELETE";
    r.headers["Access-Control-Allow-Headers"] = "Authorization, Content-Type, X-Filename";
    r.headers["Access-Control-Max-Age"] = "600";
    return r;
  }

  // ---- answers ------------------------------------------------------------------------------
  void SendContinueThen(std::function<void()> next) {
    const auto expect = req_.Header("expect");
    if (!expect || (*expect != "100-continue" && *expect != "100-Continue")) return next();
    static const std::string kContinue = "HTTP/1.1 100 Continue\r\n\r\n";
    stream_.expires_after(seconds(ctx_.options.write_timeout_s));
    net::async_write(stream_, net::buffer(kContinue),
                     [self = shared_from_this(), next](beast::error_code ec, std::size_t) {
                       if (ec) return self->Close();
                       next();
                     });
  }

  // The largest whole body of the request's route: its own limit, within the server's.
  std::uint64_t BodyLimit() const {
    const std::size_t server = ctx_.options.max_payload_bytes;
    const std::size_t route = route_ ? route_->max_body_bytes : 0;
    return route > 0 && route < server ? route : server;
  }

  Response TooLargeProblem() const {
    return Problem(413, "Payload Too Large",
                   "the request body exceeds " + std::to_string(BodyLimit()) + " bytes");
  }

  // A new request goes to the workers, or is refused at once when their queue is full.
  void Enqueue(std::function<void()> task, bool continuation = false) {
    if (continuation) return ctx_.pool.Post(std::move(task));
    if (ctx_.pool.TryPost(std::move(task))) return;
    Response busy = Problem(503, "Service Unavailable",
                            "the server is busy (all workers occupied, queue full); retry shortly");
    busy.headers["Retry-After"] = "1";
    Respond(std::move(busy), has_body_);
  }

  void Post(std::function<void()> fn) { net::post(stream_.get_executor(), std::move(fn)); }

  void PostRespond(Response res, bool close) {
    ctx_.router.Observe(req_, route_, res);
    Post([self = shared_from_this(), res = std::move(res), close]() mutable {
      self->Respond(std::move(res), close);
    });
  }

  // close: the connection ends after the answer (also when a body was left unread).
  void Respond(Response res, bool close) {
    Record(res);
    const bool body_unread =
        has_body_ && !(body_ && body_->is_done()) && !(stream_body_ && stream_body_->is_done());
    ++served_;
    keep_ = keep_alive_ && !close && !body_unread && served_ < ctx_.options.keep_alive_max_count;
    drain_ = body_unread;
    auto out = std::make_shared<http::response<http::string_body>>();
    out->version(11);
    out->result(static_cast<unsigned>(res.status));
    out->set(http::field::content_type, res.content_type);
    for (const auto& [k, v] : res.headers) out->set(k, v);
    out->set("X-Content-Type-Options", "nosniff");
    if (!out->count("Content-Security-Policy")) {
      const bool page = res.content_type.rfind("text/html", 0) == 0;
      out->set("Content-Security-Policy", page ? kPageCsp : kApiCsp);
    }
    out->set("Referrer-Policy", "no-referrer");
    if (OriginAllowed()) {
      out->set("Access-Control-Allow-Origin", *req_.Header("origin"));
      out->set("Access-Control-Expose-Headers",
               "Location, Retry-After, X-Request-Id, X-Machine-Version, ETag");
    }
    if (!ctx_.options.cors_origins.empty()) out->set("Vary", "Origin");
    if (!req_.id.empty()) out->set("X-Request-Id", req_.id);
    out->keep_alive(keep_);
    out->body() = std::move(res.body);
    out->prepare_payload();
    if (head_) out->body().clear();  // Content-Length stays that of the GET answer
    stream_.expires_after(seconds(ctx_.options.write_timeout_s));
    http::async_write(stream_, *out,
                      [self = shared_from_this(), out](beast::error_code ec, std::size_t) {
                        self->OnWritten(ec);
                      });
  }

  void OnWritten(beast::error_code ec) {
    EndRequest();
    if (ec) return Close();
    if (!keep_) return drain_ ? Drain() : Close();
    header_.reset();
    body_.reset();
    stream_body_.reset();
    sink_.reset();
    route_ = nullptr;
    ReadHeader();
  }

  // ---- telemetry: in flight from the end of the headers until the answer is written --------
  void BeginRequest() {
    req_ = Request{};
    started_ = std::chrono::steady_clock::now();
    in_flight_ = true;
    ++ctx_.in_flight;
    ProcessMetrics().Begin();
  }

  void EndRequest() {
    if (!in_flight_) return;
    in_flight_ = false;
    --ctx_.in_flight;
    ProcessMetrics().End();
  }

  // Counts the answer and writes its access-log line (never the token, only its id).
  void Record(const Response& res) const {
    RequestRecord r;
    // Both arms string_view: a std::string arm would make "HEAD" a temporary string.
    r.method = head_ ? std::string_view("HEAD") : std::string_view(req_.method);
    r.route = req_.route;
    r.path = req_.path;
    r.status = res.status;
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    r.bytes = res.body.size();
    r.request_bytes = req_.body.size();
    r.response_body = res.body;
    r.token_id = req_.token_id;
    r.remote = req_.remote_addr;
    r.request_id = req_.id;
    ProcessMetrics().Count(r);
    if (ctx_.options.on_answer) ctx_.options.on_answer(r);
  }

  // After refusing a request whose body was not read: stop sending, read (and drop) a little of
  // what the client is still sending so that it sees the answer rather than a reset.
  void Drain() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.expires_after(seconds(2));
    DrainSome();
  }

  void DrainSome() {
    stream_.async_read_some(net::buffer(discard_),
                            [self = shared_from_this()](beast::error_code ec, std::size_t n) {
                              self->drained_ += n;
                              if (ec || self->drained_ > kMaxDrainBytes) return self->Close();
                              self->DrainSome();
                            });
  }

  void Close() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
    stream_.close();
  }

  beast::tcp_stream stream_;
  ServerContext& ctx_;
  const std::string remote_addr_;  // the client's address ("" when it could not be read)
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::empty_body>> header_;
  std::optional<http::request_parser<http::string_body>> body_;
  std::optional<http::request_parser<http::buffer_body>> stream_body_;
  std::unique_ptr<BodySink> sink_;
  std::string piece_;
  std::array<char, 16384> discard_{};
  Request req_;
  const Route* route_ = nullptr;
  int served_ = 0;
  std::chrono::steady_clock::time_point started_;
  bool in_flight_ = false;
  std::size_t drained_ = 0;
  bool head_ = false, keep_alive_ = false, has_body_ = false, keep_ = false, drain_ = false;
  bool waiting_ = false, evicted_ = false;
  std::uint64_t registry_id_ = 0;
};

}  // namespace

std::string ServerContext::NextRequestId() {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%06llx",
                static_cast<unsigned long long>(requests.fetch_add(1) + 1));
  return request_id_prefix + "-" + buf;
}

void StartSession(tcp::socket socket, std::string address, ServerContext& context) {
  std::make_shared<Session>(std::move(socket), address, context)->Start();
}

}  // namespace km::api
