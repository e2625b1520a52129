// The metrics and the access log of api/metrics.h on known records: exact counter values and
// histogram buckets (a latency equal to a bound is in that bound's bucket), label values
// escaped, the jobs family only with a service; an access-log line is one JSON object with the
// keys in order, the raw path cut to 200 bytes, invalid UTF-8 replaced, and the token's id only.
#include "api/metrics.h"

#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

namespace km::api {
namespace {

RequestRecord Record(std::string_view method, std::string_view route, int status, double seconds) {
  RequestRecord r;
  r.method = method;
  r.route = route;
  r.path = route;
  r.status = status;
  r.seconds = seconds;
  return r;
}

bool Has(const std::string& text, const std::string& line) {
  return text.find("\n" + line + "\n") != std::string::npos;
}

TEST(Metrics, CountsByRouteAndClassIntoCumulativeBuckets) {
  Metrics m;
  m.Count(Record("GET", "/api/v1/measurements/{id}", 200, 0.005));  // on the bound: le=0.005
  m.Count(Record("GET", "/api/v1/measurements/{id}", 404, 0.0051));
  m.Count(Record("GET", "/api/v1/measurements/{id}", 200, 20.0));  // beyond 10 s: +Inf only
  m.Count(Record("POST", "", 405, 0.2));
  m.Count(Record("GET", "/x\"y\\z", 503, 0.001));
  const std::string t = m.Exposition(nullptr);
  EXPECT_TRUE(Has(t,
                  "kinemetric_http_requests_total{method=\"GET\",route=\"/api/v1/"
                  "measurements/{id}\",code=\"2xx\"} 2"))
      << t;
  EXPECT_TRUE(Has(t,
                  "kinemetric_http_requests_total{method=\"GET\",route=\"/api/v1/"
                  "measurements/{id}\",code=\"4xx\"} 1"));
  EXPECT_TRUE(
      Has(t, "kinemetric_http_requests_total{method=\"POST\",route=\"none\",code=\"4xx\"} 1"));
  EXPECT_TRUE(Has(
      t, "kinemetric_http_requests_total{method=\"GET\",route=\"/x\\\"y\\\\z\",code=\"5xx\"} 1"));
  EXPECT_TRUE(Has(t, "kinemetric_http_request_duration_seconds_bucket{le=\"0.005\"} 2"));
  EXPECT_TRUE(Has(t, "kinemetric_http_request_duration_seconds_bucket{le=\"0.01\"} 3"));
  EXPECT_TRUE(Has(t, "kinemetric_http_request_duration_seconds_bucket{le=\"0.25\"} 4"));
  EXPECT_TRUE(Has(t, "kinemetric_http_request_duration_seconds_bucket{le=\"10\"} 4"));
  EXPECT_TRUE(Has(t, "kinemetric_http_request_duration_seconds_bucket{le=\"+Inf\"} 5"));
  EXPECT_TRUE(Has(t, "kinemetric_http_request_duration_seconds_count 5"));
  EXPECT_TRUE(Has(t, "kinemetric_http_request_duration_seconds_sum 20.2111"));
  EXPECT_TRUE(Has(t, "# TYPE kinemetric_http_request_duration_seconds histogram"));
  EXPECT_EQ(t.find("kinemetric_jobs"), std::string::npos);  // no service: no jobs family
}

TEST(Metrics, CountsStoredUploadsAndStreamFrames) {
  Metrics m;
  auto up = Record("POST", "/api/v1/measurements", 201, 0.01);
  up.request_bytes = 4021;
  m.Count(up);
  up.status = 200;  // the same bytes again: nothing stored
  m.Count(up);
  auto frames = Record("POST", "/api/v1/streams/{id}/frames", 200, 0.01);
  frames.response_body = R"({"frames": 3, "samples": 25, "stored": 25, "gaps": [{}, {}]})";
  m.Count(frames);
  frames.response_body = "not json";
  m.Count(frames);
  m.Begin();
  m.Begin();
  m.End();
  const std::string t = m.Exposition(nullptr);
  EXPECT_TRUE(Has(t, "kinemetric_measurements_stored_total 1")) << t;
  EXPECT_TRUE(Has(t, "kinemetric_measurement_bytes_stored_total 4021"));
  EXPECT_TRUE(Has(t, "kinemetric_stream_frames_total 3"));
  EXPECT_TRUE(Has(t, "kinemetric_stream_samples_total 25"));
  EXPECT_TRUE(Has(t, "kinemetric_stream_gaps_total 2"));
  EXPECT_TRUE(Has(t, "kinemetric_http_requests_in_flight 1"));
}

TEST(AccessLog, OneJsonObjectWithTheTokenIdOnly) {
  std::string path = "/api/v1/measurements/\"\xff";
  path += std::string(300, 'a');
  RequestRecord r = Record("GET", "/api/v1/measurements/{id}", 404, 0.0012345);
  r.path = path;
  r.token_id = server::TokenId(7);
  r.bytes = 99;
  r.remote = "127.0.0.1";
  r.request_id = "abc-000001";
  const std::string line = AccessLogLine(r);
  EXPECT_EQ(line.find('\n'), std::string::npos);
  const auto j = nlohmann::ordered_json::parse(line);
  std::vector<std::string> keys;
  for (const auto& [k, v] : j.items()) keys.push_back(k);
  EXPECT_EQ(keys, (std::vector<std::string>{"time", "method", "route", "path", "status",
                                            "latency_ms", "bytes", "request_bytes", "token_id",
                                            "remote", "request_id"}));
  EXPECT_EQ(j["route"], "/api/v1/measurements/{id}");
  EXPECT_EQ(j["status"], 404);
  EXPECT_DOUBLE_EQ(j["latency_ms"].get<double>(), 1.234);
  EXPECT_EQ(j["token_id"], 7);
  const std::string logged = j["path"];
  EXPECT_EQ(logged.rfind("/api/v1/measurements/\"\xef\xbf\xbd", 0), 0u);  // U+FFFD
  EXPECT_EQ(logged.size(), 200u + 2u);  // 200 bytes, the bad byte replaced by 3
  EXPECT_TRUE(AccessLogLine(Record("GET", "", 404, 0)).find("\"route\":null") != std::string::npos);
}

// A client inventing request methods adds no series: every method outside RFC 9110's (and
// PATCH) is one label, OTHER.
TEST(Metrics, InventedMethodsShareOneSeries) {
  Metrics m;
  for (int i = 0; i < 5000; ++i) m.Count(Record("X" + std::to_string(i), "", 405, 0.001));
  m.Count(Record("PATCH", "", 405, 0.001));
  const std::string t = m.Exposition(nullptr);
  EXPECT_TRUE(
      Has(t, "kinemetric_http_requests_total{method=\"OTHER\",route=\"none\",code=\"4xx\"} 5000"))
      << t;
  EXPECT_EQ(t.find("method=\"X1\""), std::string::npos);
  EXPECT_NE(t.find("method=\"PATCH\""), std::string::npos);
  EXPECT_LT(t.size(), 20000u);
}

}  // namespace
}  // namespace km::api
