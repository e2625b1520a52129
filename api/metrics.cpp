#include "api/metrics.h"

#include <chrono>
#include <cinttypes>
#include <cstdlib>
#include <iostream>

#include "api/endpoints.h"
#include "api/route_util.h"
#include "server/storage/storage.h"

namespace km::api {
namespace {

constexpr std::size_t kMaxLoggedPath = 200;
constexpr const char* kFramesRoute = "/api/v1/streams/{id}/frames";
constexpr const char* kUploadRoute = "/api/v1/measurements";

double UnixNow() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// "2026-11-27T03:04:05.123456Z"
std::string UtcNow() {
  const auto now = std::chrono::system_clock::now().time_since_epoch();
  return server::UtcIso8601FromMicros(
      std::chrono::duration_cast<std::chrono::microseconds>(now).count());
}

// A label value as the exposition format wants it: backslash, quote and newline escaped.
std::string LabelValue(std::string_view v) {
  std::string out;
  for (const char c : v) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

// The shortest of %.15g and %.17g that reads back as the same value.
std::string Number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.15g", v);
  if (std::strtod(buf, nullptr) != v) std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void Family(std::string& out, const char* name, const char* type, const char* help) {
  out += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n";
}

void Sample(std::string& out, const std::string& name, const std::string& labels, double v) {
  out += name + (labels.empty() ? "" : "{" + labels + "}") + " " + Number(v) + "\n";
}

std::string DeviceLabels(const json& d) {
  return "device=\"" + LabelValue(d.value("name", "")) + "\",machine_id=\"" +
         LabelValue(d.value("machine_id", "")) + "\"";
}

// A device's status object (server/streams/acquisition.h Devices()); empty when absent.
const json& StatusOf(const json& device) {
  static const json kNone = json::object();
  const auto it = device.find("status");
  return it != device.end() ? *it : kNone;
}

// A whole number of a device's status object (0 when absent).
double StatusCount(const json& status, const char* key) {
  const auto it = status.find(key);
  return it != status.end() && it->is_number() ? it->get<double>() : 0.0;
}

// Errors of the Modbus devices by kind.
void ModbusErrors(std::string& out, const json& devices) {
  Family(out, "kinemetric_modbus_errors_total", "counter",
         "Modbus errors by kind: exception responses, timeouts, malformed responses, failed "
         "connections");
  for (const auto& d : devices) {
    const json& s = StatusOf(d);
    for (const auto& [kind, key] :
         {std::pair{"exception", "exceptions"}, std::pair{"timeout", "timeouts"},
          std::pair{"protocol", "protocol_errors"}, std::pair{"connection", "connection_errors"}}) {
      Sample(out, "kinemetric_modbus_errors_total", DeviceLabels(d) + ",kind=\"" + kind + "\"",
             StatusCount(s, key));
    }
  }
}

// The Modbus acquisition devices (server/streams/acquisition.h) from their status: one series per
// device, labelled with its name and machine. Their counters start at 0 again when a device
// restarts (a server start, a device added again), which Prometheus' rate() takes as a reset.
void ModbusFamilies(std::string& out, const json& devices) {
  struct Row {
    const char *name, *type, *help, *key;
  };
  static const Row kRows[] = {
      {"kinemetric_modbus_device_connected", "gauge", "Modbus devices: 1 while connected",
       "connected"},
      {"kinemetric_modbus_polls_total", "counter",
       "Modbus polls at which every register block was read", "polls_ok"},
      {"kinemetric_modbus_samples_total", "counter",
       "Samples a Modbus device delivered into its stream", "samples_delivered"},
      {"kinemetric_modbus_skipped_ticks_total", "counter",
       "Modbus poll ticks at which a block was not read (each one a gap in the stream)",
       "skipped_ticks"},
      {"kinemetric_modbus_reconnects_total", "counter", "Modbus connections made again",
       "reconnects"}};
  for (const auto& row : kRows) {
    Family(out, row.name, row.type, row.help);
    for (const auto& d : devices) {
      const json& s = StatusOf(d);
      const bool connected = s.value("connected", false);
      Sample(out, row.name, DeviceLabels(d),
             std::string_view(row.key) == "connected" ? (connected ? 1.0 : 0.0)
                                                      : StatusCount(s, row.key));
    }
  }
  ModbusErrors(out, devices);
}

// A request's method as a metrics label: the methods of RFC 9110 and PATCH as they are, any
// other word a client may invent as "OTHER", so that no client can add series without end.
std::string_view MethodLabel(std::string_view method) {
  static constexpr std::string_view kKnown[] = {"GET",     "HEAD",  "POST",    "PUT",  "DELETE",
                                                "OPTIONS", "PATCH", "CONNECT", "TRACE"};
  for (const auto m : kKnown) {
    if (m == method) return m;
  }
  return "OTHER";
}

}  // namespace

Metrics::Metrics() : start_unix_(UnixNow()) {}

void Metrics::Count(const RequestRecord& r) {
  const auto micros = static_cast<std::uint64_t>(r.seconds * 1e6);
  std::size_t b = 0;
  while (b < kLatencyBuckets.size() && r.seconds > kLatencyBuckets[b]) ++b;
  buckets_[b].fetch_add(1, std::memory_order_relaxed);
  latency_count_.fetch_add(1, std::memory_order_relaxed);
  latency_micros_.fetch_add(micros, std::memory_order_relaxed);
  const int cls = r.status >= 100 && r.status < 600 ? r.status / 100 - 1 : 4;
  {
    std::lock_guard lock(mu_);
    auto& row = requests_[{std::string(MethodLabel(r.method)),
                           r.route.empty() ? "none" : std::string(r.route)}];
    ++row[static_cast<std::size_t>(cls)];
  }
  if (r.method == "POST" && r.route == kUploadRoute && r.status == 201) {
    measurements_.fetch_add(1, std::memory_order_relaxed);
    measurement_bytes_.fetch_add(r.request_bytes, std::memory_order_relaxed);
  }
  // 408 / 499: a frames upload cut off mid-body; what arrived was stored and is counted too.
  const bool frames_kept = r.status == 200 || r.status == 408 || r.status == 499;
  if (r.method == "POST" && r.route == kFramesRoute && frames_kept) {
    const auto j = json::parse(r.response_body, nullptr, false);
    if (!j.is_object()) return;
    const auto count = [&](const char* key) -> std::uint64_t {
      const auto it = j.find(key);
      return it != j.end() && it->is_number_unsigned() ? it->get<std::uint64_t>() : 0;
    };
    frames_.fetch_add(count("frames"), std::memory_order_relaxed);
    samples_.fetch_add(count("samples"), std::memory_order_relaxed);
    const auto gaps = j.find("gaps");
    if (gaps != j.end() && gaps->is_array()) gaps_.fetch_add(gaps->size());
  }
}

std::string Metrics::Exposition(server::Service* service) const {
  std::string out;
  Family(out, "kinemetric_http_requests_total", "counter",
         "HTTP requests answered, by method, route pattern and status class");
  {
    static const char* kClasses[] = {"1xx", "2xx", "3xx", "4xx", "5xx"};
    std::lock_guard lock(mu_);
    for (const auto& [key, row] : requests_) {
      for (std::size_t c = 0; c < row.size(); ++c) {
        if (row[c] == 0) continue;
        Sample(out, "kinemetric_http_requests_total",
               "method=\"" + LabelValue(key.first) + "\",route=\"" + LabelValue(key.second) +
                   "\",code=\"" + kClasses[c] + "\"",
               static_cast<double>(row[c]));
      }
    }
  }
  Family(out, "kinemetric_http_request_duration_seconds", "histogram",
         "Time from a request's headers to its answer");
  std::uint64_t cumulative = 0;
  for (std::size_t b = 0; b < buckets_.size(); ++b) {
    cumulative += buckets_[b].load(std::memory_order_relaxed);
    const std::string le = b < kLatencyBuckets.size() ? Number(kLatencyBuckets[b]) : "+Inf";
    Sample(out, "kinemetric_http_request_duration_seconds_bucket", "le=\"" + le + "\"",
           static_cast<double>(cumulative));
  }
  Sample(out, "kinemetric_http_request_duration_seconds_sum", "",
         static_cast<double>(latency_micros_.load()) / 1e6);
  Sample(out, "kinemetric_http_request_duration_seconds_count", "",
         static_cast<double>(cumulative));
  Family(out, "kinemetric_http_requests_in_flight", "gauge",
         "Requests whose headers were read and whose answer is not yet given");
  Sample(out, "kinemetric_http_requests_in_flight", "", static_cast<double>(in_flight_.load()));
  if (service) {
    Family(out, "kinemetric_jobs", "gauge", "Background jobs by status");
    auto counts = service->storage().CountJobsByStatus();
    for (auto s :
         {server::JobStatus::kQueued, server::JobStatus::kRunning, server::JobStatus::kDone,
          server::JobStatus::kFailed, server::JobStatus::kCancelled}) {
      counts.try_emplace(ToString(s), 0);
    }
    for (const auto& [status, n] : counts) {
      Sample(out, "kinemetric_jobs", "status=\"" + LabelValue(status) + "\"",
             static_cast<double>(n));
    }
    ModbusFamilies(out, service->streams().acquisition().Devices());
  }
  const std::pair<const char*, const std::atomic<std::uint64_t>*> counters[] = {
      {"kinemetric_measurements_stored_total", &measurements_},
      {"kinemetric_measurement_bytes_stored_total", &measurement_bytes_},
      {"kinemetric_stream_frames_total", &frames_},
      {"kinemetric_stream_samples_total", &samples_},
      {"kinemetric_stream_gaps_total", &gaps_},
  };
  const char* helps[] = {"Measurement files uploaded and stored (answered 201)",
                         "Bytes of the measurement files stored",
                         "Stream frames received over HTTP", "Stream samples received over HTTP",
                         "Stream gaps (counter jumps) found in frames received over HTTP"};
  for (std::size_t i = 0; i < std::size(counters); ++i) {
    Family(out, counters[i].first, "counter", helps[i]);
    Sample(out, counters[i].first, "", static_cast<double>(counters[i].second->load()));
  }
  Family(out, "process_start_time_seconds", "gauge", "Start time of the process (Unix seconds)");
  Sample(out, "process_start_time_seconds", "", start_unix_);
  return out;
}

Metrics& ProcessMetrics() {
  static Metrics metrics;
  return metrics;
}

std::string AccessLogLine(const RequestRecord& r) {
  const std::string path(r.path.substr(0, kMaxLoggedPath));
  const nlohmann::ordered_json j = {
      {"time", UtcNow()},
      {"method", std::string(r.method)},
      {"route", r.route.empty() ? nullptr : nlohmann::ordered_json(std::string(r.route))},
      {"path", path},
      {"status", r.status},
      {"latency_ms", static_cast<double>(static_cast<std::int64_t>(r.seconds * 1e6)) / 1e3},
      {"bytes", r.bytes},
      {"request_bytes", r.request_bytes},
      {"token_id", server::ValueOrZero(r.token_id)},
      {"remote", std::string(r.remote)},
      {"request_id", std::string(r.request_id)}};
  return j.dump(-1, ' ', true, nlohmann::ordered_json::error_handler_t::replace);
}

AccessLog::AccessLog(const std::string& target) {
  if (target.empty() || target == "off") return;
  if (target == "-") {
    out_ = stderr;
    return;
  }
  out_ = std::fopen(target.c_str(), "a");
  if (!out_) throw Error("cannot open the access log '" + target + "' for appending");
  owned_ = true;
}

AccessLog::~AccessLog() {
  if (owned_ && out_) std::fclose(out_);
}

void AccessLog::Write(const RequestRecord& r) {
  if (!out_) return;
  std::string line = AccessLogLine(r);
  line += '\n';
  std::lock_guard lock(mu_);
  std::fwrite(line.data(), 1, line.size(), out_);
  std::fflush(out_);
}

namespace endpoints {

Endpoint OperationsMetrics(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Operations metrics in the Prometheus text format: requests by route and status class, "
      "latency histogram, requests in flight, jobs by status, uploads and stream counters",
      [svc](const Request&) {
        Response r;
        r.content_type = "text/plain; version=0.0.4; charset=utf-8";
        r.body = ProcessMetrics().Exposition(svc);
        r.headers["Cache-Control"] = "no-store";
        return r;
      },
      {{"responses", {{"200", {{"description", "Prometheus text exposition (0.0.4)"}}}}}}};
}

}  // namespace endpoints

}  // namespace km::api
