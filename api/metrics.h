// Operations telemetry of the HTTP server: one record per answered request, counted into
// process-wide metrics (served as Prometheus text at GET /metrics) and written as one JSON line
// to the access log. Counting is a few atomic increments and one short lock per request; the
// exposition text is made only when scraped.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include "api/http.h"
#include "server/service.h"

namespace km::api {

// What the access log and the metrics keep of one answered request. Never the token itself:
// only the id of its row in the tokens table (0 without a valid token).
struct RequestRecord {
  std::string_view method;
  std::string_view route;  // the route pattern ("/api/v1/measurements/{id}"); "" when none
  std::string_view path;   // the raw path (without the query)
  int status = 0;
  double seconds = 0;                       // from the end of the request headers to the answer
  std::uint64_t bytes = 0;                  // the answer's body
  std::uint64_t request_bytes = 0;          // the request's body when read whole
  std::string_view response_body;           // read for the counts of stream-frame answers
  std::optional<server::TokenId> token_id;  // none: no valid token
  std::string_view remote;
  std::string_view request_id;
};

// Latency histogram bounds in seconds (Prometheus "le" labels); the last bucket is +Inf.
inline constexpr std::array<double, 11> kLatencyBuckets = {0.005, 0.01, 0.025, 0.05, 0.1, 0.25,
                                                           0.5,   1.0,  2.5,   5.0,  10.0};

class Metrics {
 public:
  Metrics();
  // A request's headers were read / its answer was handed over or abandoned.
  void Begin() { in_flight_.fetch_add(1, std::memory_order_relaxed); }
  void End() { in_flight_.fetch_sub(1, std::memory_order_relaxed); }
  // Counts an answered request: by route and status class, its latency, and what it stored
  // (measurements uploaded, stream frames, samples and gaps received).
  void Count(const RequestRecord& r);
  // The Prometheus text exposition (version 0.0.4); jobs by status are read from the service.
  std::string Exposition(server::Service* service) const;

 private:
  std::atomic<std::int64_t> in_flight_{0};
  std::array<std::atomic<std::uint64_t>, kLatencyBuckets.size() + 1> buckets_{};
  std::atomic<std::uint64_t> latency_count_{0};
  std::atomic<std::uint64_t> latency_micros_{0};
  std::atomic<std::uint64_t> measurements_{0}, measurement_bytes_{0};
  std::atomic<std::uint64_t> frames_{0}, samples_{0}, gaps_{0};
  double start_unix_ = 0;
  mutable std::mutex mu_;
  // (method, route, status class "2xx") → requests
  std::map<std::pair<std::string, std::string>, std::array<std::uint64_t, 5>> requests_;
};

// The metrics of this process (every server in it counts here).
Metrics& ProcessMetrics();

// The access log: one JSON line per request (time, method, route, path, status, latency_ms,
// bytes, request_bytes, token_id, remote, request_id). target: "-" is stderr, "off" or ""
// writes nothing, anything else is a file appended to.
class AccessLog {
 public:
  explicit AccessLog(const std::string& target);
  ~AccessLog();
  AccessLog(const AccessLog&) = delete;
  AccessLog& operator=(const AccessLog&) = delete;
  bool enabled() const { return out_ != nullptr; }
  void Write(const RequestRecord& r);

 private:
  std::FILE* out_ = nullptr;
  bool owned_ = false;
  std::mutex mu_;
};

// One access-log line (without the newline); the raw path is cut to 200 bytes and escaped.
std::string AccessLogLine(const RequestRecord& r);

}  // namespace km::api
