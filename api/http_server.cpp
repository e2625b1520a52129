#include "api/http_server.h"

#include <httplib.h>

#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include "analysis/core/errors.h"

namespace km::api {
namespace {

// Worker pool with a bounded queue: enqueue blocks while the queue is full.
class BoundedPool : public httplib::TaskQueue {
 public:
  BoundedPool(int threads, std::size_t limit) : limit_(limit) {
    for (int i = 0; i < threads; ++i) workers_.emplace_back([this] { Work(); });
  }
  ~BoundedPool() override = default;

  void enqueue(std::function<void()> fn) override {
    std::unique_lock lock(mu_);
    not_full_.wait(lock, [&] { return jobs_.size() < limit_ || stop_; });
    jobs_.push_back(std::move(fn));
    not_empty_.notify_one();
  }

  void shutdown() override {
    {
      std::lock_guard lock(mu_);
      stop_ = true;
    }
    not_empty_.notify_all();
    not_full_.notify_all();
    for (auto& t : workers_) t.join();
  }

 private:
  void Work() {
    while (true) {
      std::function<void()> fn;
      {
        std::unique_lock lock(mu_);
        not_empty_.wait(lock, [&] { return !jobs_.empty() || stop_; });
        if (jobs_.empty()) return;  // stopping and drained
        fn = std::move(jobs_.front());
        jobs_.pop_front();
        not_full_.notify_one();
      }
      fn();
    }
  }

  std::size_t limit_;
  std::vector<std::thread> workers_;
  std::deque<std::function<void()>> jobs_;
  std::mutex mu_;
  std::condition_variable not_empty_, not_full_;
  bool stop_ = false;
};

std::string ContentTypeFor(const std::filesystem::path& p) {
  const auto ext = p.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".png") return "image/png";
  if (ext == ".json") return "application/json";
  return "application/octet-stream";
}

}  // namespace

struct HttpServer::Impl {
  const Router& router;
  HttpOptions options;
  httplib::Server server;
  explicit Impl(const Router& r, HttpOptions o) : router(r), options(std::move(o)) {}

  void ServeStatic(const httplib::Request& req, httplib::Response& res) {
    namespace fs = std::filesystem;
    std::string rel =
        req.path == "/" ? "index.html" : req.path.substr(std::string("/static/").size());
    // Only plain names below the root: no "..", no hidden files.
    if (rel.empty() || rel.find("..") != std::string::npos || rel.front() == '/' ||
        rel.front() == '.') {
      res.status = 404;
      return;
    }
    const fs::path p = fs::path(options.static_root) / rel;
    std::ifstream in(p, std::ios::binary);
    if (options.static_root.empty() || !in) {
      const auto pr = Problem(404, "Not Found", "no such file: " + req.path);
      res.status = pr.status;
      res.set_content(pr.body, pr.content_type.c_str());
      return;
    }
    std::ostringstream ss;
    ss << in.rdbuf();
    res.set_content(ss.str(), ContentTypeFor(p).c_str());
    res.set_header("Cache-Control", "no-cache");
  }

  void Handle(const httplib::Request& hreq, httplib::Response& hres,
              const httplib::ContentReader* reader = nullptr) {
    Request req;
    req.method = hreq.method;
    req.path = hreq.path;
    for (const auto& [k, v] : hreq.params) req.query.emplace(k, v);
    for (const auto& [k, v] : hreq.headers) {
      std::string lower = k;
      for (auto& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      req.headers[lower] = v;
    }
    req.body = hreq.body;
    req.remote_addr = hreq.remote_addr;
    if (reader) {
      req.read_body = [reader](const std::function<bool(std::string_view)>& sink) {
        return (*reader)(
            [&sink](const char* data, std::size_t n) { return sink(std::string_view(data, n)); });
      };
    }
    const Response res = router.Dispatch(req);
    hres.status = res.status;
    for (const auto& [k, v] : res.headers) hres.set_header(k.c_str(), v);
    hres.set_header("X-Content-Type-Options", "nosniff");
    hres.set_content(res.body, res.content_type.c_str());
  }
};

HttpServer::HttpServer(const Router& router, HttpOptions options)
    : impl_(std::make_unique<Impl>(router, std::move(options))) {
  auto& s = impl_->server;
  const auto& o = impl_->options;
  s.set_payload_max_length(o.max_payload_bytes);
  s.set_read_timeout(o.read_timeout_s, 0);
  s.set_write_timeout(o.write_timeout_s, 0);
  s.set_keep_alive_max_count(static_cast<std::size_t>(o.keep_alive_max_count));
  s.set_keep_alive_timeout(o.keep_alive_timeout_s);
  const int threads = o.threads;
  const std::size_t limit = o.queue_limit;
  s.new_task_queue = [threads, limit] { return new BoundedPool(threads, limit); };
  Impl* impl = impl_.get();
  s.Get("/", [impl](const httplib::Request& q, httplib::Response& r) { impl->ServeStatic(q, r); });
  s.Get("/static/.*",
        [impl](const httplib::Request& q, httplib::Response& r) { impl->ServeStatic(q, r); });
  auto api = [impl](const httplib::Request& q, httplib::Response& r) { impl->Handle(q, r); };
  // Bodies are read raw, whatever their Content-Type: a measurement file sent as
  // application/x-www-form-urlencoded (curl --data-binary) must not be parsed as a form.
  // Routes that stream their body (sensor frames) read it piece by piece; every other body is
  // read whole, capped at the payload limit also when it arrives chunked (httplib checks only
  // Content-Length).
  auto with_body = [impl](const httplib::Request& q, httplib::Response& r,
                          const httplib::ContentReader& reader) {
    if (impl->router.StreamsBody(q.method, q.path)) {
      impl->Handle(q, r, &reader);
      return;
    }
    httplib::Request copy = q;
    copy.body.clear();
    bool too_large = false;
    const std::size_t limit = impl->options.max_payload_bytes;
    reader([&](const char* data, std::size_t n) {
      if (copy.body.size() + n > limit) {
        too_large = true;
        return false;
      }
      copy.body.append(data, n);
      return true;
    });
    if (too_large) {
      const auto pr = Problem(413, "Payload Too Large",
                              "the request body exceeds " + std::to_string(limit) + " bytes");
      r.status = pr.status;
      r.set_content(pr.body, pr.content_type.c_str());
      return;
    }
    impl->Handle(copy, r);
  };
  s.Get(".*", api);
  s.Post(".*", with_body);
  s.Put(".*", with_body);
  s.Patch(".*", with_body);
  s.Delete(".*", api);
  s.set_exception_handler([](const httplib::Request&, httplib::Response& r, std::exception_ptr) {
    const auto pr = Problem(500, "Internal Server Error", "unexpected error");
    r.status = pr.status;
    r.set_content(pr.body, pr.content_type.c_str());
  });
  // Requests over the payload limit are refused by httplib with 413 before reaching a route.
  s.set_error_handler([](const httplib::Request&, httplib::Response& r) {
    if (!r.body.empty()) return;
    const auto pr = Problem(r.status, r.status == 413 ? "Payload Too Large" : "HTTP error",
                            "the request was refused (status " + std::to_string(r.status) + ")");
    r.set_content(pr.body, pr.content_type.c_str());
  });
}

HttpServer::~HttpServer() {
  Stop();
}

int HttpServer::Bind() {
  auto& s = impl_->server;
  const auto& o = impl_->options;
  if (o.port == 0) {
    const int port = s.bind_to_any_port(o.host);
    if (port <= 0) throw Error("cannot bind to " + o.host);
    return port;
  }
  if (!s.bind_to_port(o.host, o.port)) {
    throw Error("cannot bind to " + o.host + ":" + std::to_string(o.port) +
                " (is another server running there?)");
  }
  return o.port;
}

void HttpServer::Serve() {
  impl_->server.listen_after_bind();
}

void HttpServer::Stop() {
  if (impl_) impl_->server.stop();
}

}  // namespace km::api
