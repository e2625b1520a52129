// Capacitance-sensor streams over HTTP against a real kinemetricd: sustained multi-channel
// streaming in one chunked request with zero lost samples, a deliberately dropped frame recorded
// as a gap, NDJSON with resends and a bad line, restart, downsampled reads, and a stream turned
// into a straightness profile.
#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <string>
#include <thread>

#include "ingest/stream/stream_frames.h"
#include "tests/integration/server/server_process.h"

namespace {

namespace fs = std::filesystem;
using km::ingest::SampleRun;
using nlohmann::json;

constexpr const char* kToken = "stream-test-token";
constexpr const char* kBinary = "application/vnd.kinemetric.stream-frame";

// Sensor value of channel c at counter k: smooth, distinct per channel, not a round number.
double Value(std::uint32_t c, std::uint64_t k) {
  return 0.25 * std::sin(1e-3 * static_cast<double>(k) + c) + 0.01 * c + 1e-7 * (k % 97);
}

SampleRun MakeRun(std::uint32_t c, std::uint64_t first, std::size_t n, std::int64_t t0_us,
                  std::int64_t dt_us) {
  SampleRun r;
  r.channel = c;
  r.first_counter = first;
  for (std::size_t i = 0; i < n; ++i) {
    r.t_us.push_back(t0_us + static_cast<std::int64_t>(first + i) * dt_us);
    r.value_um.push_back(Value(c, first + i));
    r.status.push_back(0);
  }
  return r;
}

class Client {
 public:
  explicit Client(int port) : c_("127.0.0.1", port) {
    c_.set_read_timeout(120, 0);
    c_.set_write_timeout(30, 0);
    c_.set_default_headers({{"Authorization", std::string("Bearer ") + kToken}});
  }
  json Get(const std::string& p, int expect = 200) {
    auto r = c_.Get(p.c_str());
    EXPECT_TRUE(r) << p;
    if (!r) return json();
    EXPECT_EQ(r->status, expect) << p << ": " << r->body;
    return json::parse(r->body);
  }
  httplib::Result PostJson(const std::string& p, const json& body) {
    return c_.Post(p.c_str(), body.dump(), "application/json");
  }
  httplib::Result PostBody(const std::string& p, const std::string& body, const char* type) {
    return c_.Post(p.c_str(), body, type);
  }
  // One chunked request whose body is produced piece by piece by `next` (empty = end).
  httplib::Result PostStream(const std::string& p, const char* type,
                             std::function<std::string()> next) {
    return c_.Post(
        p.c_str(), httplib::Headers{},
        [next](std::size_t, httplib::DataSink& sink) {
          const std::string piece = next();
          if (piece.empty()) {
            sink.done();
            return true;
          }
          return sink.write(piece.data(), piece.size());
        },
        type);
  }

 private:
  httplib::Client c_;
};

class StreamIntegration : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("kinemetric-stream-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::unique_ptr<km::test::ServerProcess> Start() {
    return std::make_unique<km::test::ServerProcess>(KINEMETRICD_BIN, dir_.string(), kToken);
  }
  static std::int64_t NewStream(Client& api, int channels, double rate_hz) {
    json chans = json::array();
    for (int c = 1; c <= channels; ++c) {
      chans.push_back({{"channel", c}, {"name", "cap" + std::to_string(c)}, {"rate_hz", rate_hz}});
    }
    auto r = api.PostJson(
        "/api/v1/streams",
        {{"machine_id", "vmc-7"}, {"name", "optical flat, X travel"}, {"channels", chans}});
    EXPECT_TRUE(r);
    EXPECT_EQ(r->status, 201) << r->body;
    return json::parse(r->body)["id"].get<std::int64_t>();
  }
  fs::path dir_;
};

// 4 channels × 20 kHz in real time for KM_STREAM_SECONDS, one chunked request, binary frames of
// 10 ms; one frame of channel 3 is deliberately left out.
// CTest names must differ between the default run and the soak (same source, two programs).
#ifdef KM_STREAM_SOAK_ONLY
#define KM_SUSTAINED_TEST_NAME SoakFourChannelsAt20kHzLoseNothingAndRecordADroppedFrame
#else
#define KM_SUSTAINED_TEST_NAME SustainedFourChannelsAt20kHzLoseNothingAndRecordADroppedFrame
#endif
TEST_F(StreamIntegration, KM_SUSTAINED_TEST_NAME) {
  auto server = Start();
  Client api(server->port());
  constexpr int kChannels = 4;
  constexpr double kRate = 20000.0;
  constexpr std::int64_t kDtUs = 50;
  constexpr std::size_t kPerFrame = 200;  // 10 ms
  const std::int64_t seconds = KM_STREAM_SECONDS;
  const std::size_t frames_per_channel = static_cast<std::size_t>(seconds) * 100;
  const std::size_t dropped_frame = frames_per_channel / 2;
  const auto id = NewStream(api, kChannels, kRate);
  const std::int64_t t0 = 1'763'700'000'000'000;

  std::size_t f = 0;
  const auto start = std::chrono::steady_clock::now();
  auto r = api.PostStream("/api/v1/streams/" + std::to_string(id) + "/frames", kBinary, [&] {
    if (f == frames_per_channel) return std::string();
    // Real time: frame f is due at f × 10 ms.
    std::this_thread::sleep_until(start + std::chrono::milliseconds(10 * f));
    std::string piece;
    for (std::uint32_t c = 1; c <= kChannels; ++c) {
      if (c == 3 && f == dropped_frame) continue;
      piece += km::ingest::EncodeBinaryFrame(MakeRun(c, f * kPerFrame, kPerFrame, t0, kDtUs), false,
                                             false, 50'000);
    }
    ++f;
    return piece;
  });
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const json out = json::parse(r->body);
  const std::uint64_t per_channel = frames_per_channel * kPerFrame;
  EXPECT_EQ(out["samples"].get<std::uint64_t>(), kChannels * per_channel - kPerFrame);
  EXPECT_EQ(out["stored"].get<std::uint64_t>(), kChannels * per_channel - kPerFrame);
  EXPECT_EQ(out["duplicates"].get<std::uint64_t>(), 0u);
  ASSERT_EQ(out["gaps"].size(), 1u);
  EXPECT_EQ(out["gaps"][0]["channel"], 3);
  EXPECT_EQ(out["gaps"][0]["first_missing"].get<std::uint64_t>(), dropped_frame * kPerFrame);
  EXPECT_EQ(out["gaps"][0]["missing"].get<std::uint64_t>(), kPerFrame);
  const double rate = static_cast<double>(kChannels * per_channel) / elapsed;
  RecordProperty("samples_per_second", std::to_string(rate));
  std::printf("streamed %llu samples in %.2f s (%.0f samples/s, %.0f per channel)\n",
              static_cast<unsigned long long>(kChannels * per_channel), elapsed, rate,
              rate / kChannels);
  // The server kept up with real time: the client is paced at 4 × 20 kHz and the request ends
  // only when every sample is stored, so a server that falls behind stretches `elapsed`. The
  // sustained rate must reach 80 % of 80 000 samples/s (20 % margin for a loaded machine).
  EXPECT_GE(rate, 0.8 * kChannels * kRate)
      << "the server did not keep up with 4 channels x 20 kHz in real time";

  // Stored exactly: counts per channel, the recorded gap, and the values themselves.
  const json s = api.Get("/api/v1/streams/" + std::to_string(id));
  ASSERT_EQ(s["channels"].size(), static_cast<std::size_t>(kChannels));
  for (const auto& c : s["channels"]) {
    const bool dropped = c["channel"] == 3;
    EXPECT_EQ(c["samples"].get<std::uint64_t>(), per_channel - (dropped ? kPerFrame : 0));
    EXPECT_EQ(c["gaps"].get<int>(), dropped ? 1 : 0);
    EXPECT_EQ(c["next_counter"].get<std::uint64_t>(), per_channel);
    EXPECT_EQ(c["buffered"].get<int>(), 0);
  }
  const json gaps = api.Get("/api/v1/streams/" + std::to_string(id) + "/gaps");
  ASSERT_EQ(gaps["items"].size(), 1u);
  EXPECT_EQ(gaps["items"][0]["t_before_us"].get<std::int64_t>(),
            t0 + static_cast<std::int64_t>(dropped_frame * kPerFrame - 1) * kDtUs);
  EXPECT_EQ(gaps["items"][0]["t_after_us"].get<std::int64_t>(),
            t0 + static_cast<std::int64_t>((dropped_frame + 1) * kPerFrame) * kDtUs);
  // One second of channel 2, every sample, bit-exact.
  const std::int64_t from = t0 + 20000 * kDtUs, to = from + 20000 * kDtUs;
  const json raw = api.Get("/api/v1/streams/" + std::to_string(id) +
                           "/samples?channel=2&from_us=" + std::to_string(from) +
                           "&to_us=" + std::to_string(to) + "&max_points=100000");
  ASSERT_FALSE(raw["downsampled"].get<bool>());
  ASSERT_EQ(raw["value_um"].size(), 20000u);
  for (std::size_t i = 0; i < 20000; ++i) {
    const double want = Value(2, 20000 + i);
    const double got = raw["value_um"][i].get<double>();
    ASSERT_EQ(std::memcmp(&want, &got, sizeof want), 0) << i;
    ASSERT_EQ(raw["counter"][i].get<std::uint64_t>(), 20000 + i);
  }
  // The whole channel for a plot: at most max_points buckets that cover every sample.
  const json ds =
      api.Get("/api/v1/streams/" + std::to_string(id) + "/samples?channel=3&max_points=500");
  ASSERT_TRUE(ds["downsampled"].get<bool>());
  EXPECT_LE(ds["t_us"].size(), 500u);
  std::uint64_t covered = 0;
  for (const auto& n : ds["count"]) covered += n.get<std::uint64_t>();
  EXPECT_EQ(covered, per_channel - kPerFrame);
}

#ifndef KM_STREAM_SOAK_ONLY

constexpr const char* kNdjson = "application/x-ndjson";

TEST_F(StreamIntegration, NdjsonResendsBadLinesAndRestart) {
  std::int64_t id = 0;
  const std::int64_t t0 = 1'763'700'000'000'000;
  {
    auto server = Start();
    Client api(server->port());
    id = NewStream(api, 2, 1000.0);
    std::string body;
    for (std::uint64_t k = 0; k < 5; ++k) {
      km::ingest::StreamSample s{1, k, t0 + static_cast<std::int64_t>(k) * 1000, Value(1, k), 0};
      body += km::ingest::EncodeNdjsonSample(s);
    }
    body += km::ingest::EncodeNdjsonRun(MakeRun(1, 5, 995, t0, 1000));
    body += km::ingest::EncodeNdjsonRun(MakeRun(2, 0, 1000, t0, 1000));
    auto r = api.PostBody("/api/v1/streams/" + std::to_string(id) + "/frames", body, kNdjson);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    EXPECT_EQ(json::parse(r->body)["stored"], 2000);

    // A client resending after a timeout: overlapping samples are dropped, new ones kept.
    auto again = api.PostBody("/api/v1/streams/" + std::to_string(id) + "/frames",
                              km::ingest::EncodeNdjsonRun(MakeRun(2, 900, 200, t0, 1000)), kNdjson);
    ASSERT_EQ(again->status, 200) << again->body;
    EXPECT_EQ(json::parse(again->body)["duplicates"], 100);
    EXPECT_EQ(json::parse(again->body)["stored"], 100);

    // A bad line: 400 naming the line and field; the lines before it are stored.
    std::string bad = km::ingest::EncodeNdjsonRun(MakeRun(1, 1000, 10, t0, 1000));
    bad += R"({"channel":1,"counter":1010,"t_us":5,"value_um":"high"})"
           "\n";
    bad += km::ingest::EncodeNdjsonRun(MakeRun(1, 1011, 10, t0, 1000));
    auto rb = api.PostBody("/api/v1/streams/" + std::to_string(id) + "/frames", bad, kNdjson);
    ASSERT_EQ(rb->status, 400) << rb->body;
    EXPECT_EQ(rb->get_header_value("Content-Type"), "application/problem+json");
    const json problem = json::parse(rb->body);
    EXPECT_EQ(problem["line"], 2) << problem.dump();
    EXPECT_EQ(problem["field"], "value_um") << problem.dump();
    // Undeclared channel, unknown type, unknown stream, no token.
    auto ru = api.PostBody("/api/v1/streams/" + std::to_string(id) + "/frames",
                           km::ingest::EncodeNdjsonRun(MakeRun(7, 0, 3, t0, 1000)), kNdjson);
    EXPECT_EQ(ru->status, 400) << ru->body;
    auto rt = api.PostBody("/api/v1/streams/" + std::to_string(id) + "/frames", "x", "text/csv");
    EXPECT_EQ(rt->status, 400) << rt->body;
    auto rn = api.PostBody("/api/v1/streams/999/frames", body, kNdjson);
    EXPECT_EQ(rn->status, 404) << rn->body;
    httplib::Client anon("127.0.0.1", server->port());
    EXPECT_EQ(
        anon.Post(("/api/v1/streams/" + std::to_string(id) + "/frames").c_str(), body, kNdjson)
            ->status,
        401);
    auto bad_req = api.PostJson("/api/v1/streams", {{"name", "no machine"}});
    EXPECT_EQ(bad_req->status, 400);
    EXPECT_EQ(json::parse(bad_req->body)["field"], "machine_id");
  }
  // After a restart the stream continues where it stopped: a resend of everything adds nothing.
  auto server = Start();
  Client api(server->port());
  const json before = api.Get("/api/v1/streams/" + std::to_string(id));
  EXPECT_EQ(before["samples"], 1010 + 1100);
  std::string all = km::ingest::EncodeNdjsonRun(MakeRun(1, 0, 1010, t0, 1000));
  all += km::ingest::EncodeNdjsonRun(MakeRun(1, 1010, 1, t0, 1000));
  auto r = api.PostBody("/api/v1/streams/" + std::to_string(id) + "/frames", all, kNdjson);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(json::parse(r->body)["duplicates"], 1010);
  EXPECT_EQ(json::parse(r->body)["stored"], 1);
  const json after = api.Get("/api/v1/streams/" + std::to_string(id));
  EXPECT_EQ(after["samples"], 1010 + 1100 + 1);
  EXPECT_EQ(after["gap_count"], 0);
  const json list = api.Get("/api/v1/streams?machine_id=vmc-7");
  EXPECT_EQ(list["items"].size(), 1u);
}

// [Fujita thesis] set-up: a capacitance sensor against an optical flat while X travels at constant
// feed; a 55 mm guide waviness of 0.2 µm in 0.02 µm noise. The stream becomes a straightness
// measurement whose analysis finds the waviness.
TEST_F(StreamIntegration, StreamBecomesAStraightnessProfile) {
  auto server = Start();
  Client api(server->port());
  const auto id = NewStream(api, 2, 5000.0);
  const std::int64_t t0 = 1'763'700'000'000'000;
  const double feed = 600.0;  // mm/min: 10 mm/s, 300 mm in 30 s
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.02);
  const std::size_t n = 150000;  // 30 s at 5 kHz
  SampleRun sensor, encoder;
  sensor.channel = 1;
  encoder.channel = 2;
  for (std::size_t k = 0; k < n; ++k) {
    const std::int64_t t = t0 + static_cast<std::int64_t>(k) * 200;
    const double x = 50.0 + feed / 60.0 * static_cast<double>(k) * 200e-6;
    sensor.t_us.push_back(t);
    sensor.value_um.push_back(0.2 * std::sin(2 * std::numbers::pi * x / 55.0) + 12e-3 * x +
                              noise(rng));
    sensor.status.push_back(0);
    encoder.t_us.push_back(t);
    encoder.value_um.push_back(x * 1000.0);
    encoder.status.push_back(0);
  }
  std::string body;
  for (std::size_t b = 0; b < n; b += 5000) {
    for (auto* run : {&sensor, &encoder}) {
      SampleRun part;
      part.channel = run->channel;
      part.first_counter = b;
      part.t_us.assign(run->t_us.begin() + b, run->t_us.begin() + b + 5000);
      part.value_um.assign(run->value_um.begin() + b, run->value_um.begin() + b + 5000);
      part.status.assign(5000, 0);
      body += km::ingest::EncodeBinaryFrame(part, true, false, 0);
    }
  }
  auto r = api.PostBody("/api/v1/streams/" + std::to_string(id) + "/frames", body, kBinary);
  ASSERT_EQ(r->status, 200) << r->body;
  json encoder_results;
  for (const json& position :
       {json{{"feed_mm_min", feed}, {"start_mm", 50.0}}, json{{"encoder_channel", 2}}}) {
    auto p = api.PostJson("/api/v1/streams/" + std::to_string(id) + "/profile",
                          {{"channel", 1},
                           {"axis", "X"},
                           {"error_direction", "Z"},
                           {"points", 1500},
                           {"position", position}});
    ASSERT_TRUE(p);
    ASSERT_TRUE(p->status == 201 || p->status == 200) << p->body;
    const json out = json::parse(p->body);
    EXPECT_EQ(out["kind"], "straightness");
    const json& res = out["results"];
    ASSERT_FALSE(res["periodic"].empty()) << res.dump();
    EXPECT_NEAR(res["periodic"][0]["period_mm"].get<double>(), 55.0, 55.0 * 0.02) << res.dump();
    EXPECT_NEAR(res["periodic"][0]["amplitude_um"].get<double>(), 0.2, 0.02) << res.dump();
    EXPECT_NEAR(res["slope_um_per_m"].get<double>(), 12.0, 1.0) << res.dump();
    // The measurement is stored like an upload, and says where it came from.
    const json m = api.Get("/api/v1/measurements/" + std::to_string(out["id"].get<int>()));
    EXPECT_EQ(m["machine_id"], "vmc-7");
    if (position.contains("encoder_channel")) encoder_results = res;
  }
  // The same frames captured to a file give the same figures offline (kinemetric stream
  // profile), with a dropped frame reported as a gap.
  {
    const fs::path frames = dir_ / "capture.kmsf";
    std::string capture = body;
    // Drop the second frame of channel 1 (frames alternate sensor, encoder).
    const std::size_t frame_bytes = 32 + 5000 * 16 + 4;
    capture.erase(2 * frame_bytes, frame_bytes);
    FILE* fp = std::fopen(frames.c_str(), "wb");
    std::fwrite(capture.data(), 1, capture.size(), fp);
    std::fclose(fp);
    const std::string cmd = std::string(KINEMETRIC_BIN) + " stream profile '" + frames.string() +
                            "' --channel 1 --encoder-channel 2 --axis X --error-direction Z "
                            "--points 1500 --json";
    FILE* p = popen(cmd.c_str(), "r");
    std::string text;
    char buf[4096];
    while (std::size_t n = std::fread(buf, 1, sizeof buf, p)) text.append(buf, n);
    ASSERT_EQ(pclose(p), 0) << text;
    const json cli = json::parse(text);
    ASSERT_EQ(cli["stream"]["gaps"].size(), 1u) << text;
    EXPECT_EQ(cli["stream"]["gaps"][0]["channel"], 1);
    EXPECT_EQ(cli["stream"]["gaps"][0]["first_missing"], 5000);
    EXPECT_EQ(cli["stream"]["gaps"][0]["missing"], 5000);
    EXPECT_EQ(cli["stream"]["sensor_samples"], n - 5000);
    EXPECT_NEAR(cli["periodic"][0]["period_mm"].get<double>(), 55.0, 55.0 * 0.02) << text;
    // Without the dropped frame the CLI and the server agree exactly.
    FILE* fp2 = std::fopen(frames.c_str(), "wb");
    std::fwrite(body.data(), 1, body.size(), fp2);
    std::fclose(fp2);
    FILE* p2 = popen(cmd.c_str(), "r");
    text.clear();
    while (std::size_t n2 = std::fread(buf, 1, sizeof buf, p2)) text.append(buf, n2);
    ASSERT_EQ(pclose(p2), 0) << text;
    const json cli_full = json::parse(text);
    EXPECT_EQ(cli_full["stream"]["gaps"].size(), 0u);
    EXPECT_EQ(cli_full["straightness_lsq_um"], encoder_results["straightness_lsq_um"]);
    EXPECT_EQ(cli_full["straightness_min_zone_um"], encoder_results["straightness_min_zone_um"]);
    EXPECT_EQ(cli_full["slope_um_per_m"], encoder_results["slope_um_per_m"]);
    EXPECT_EQ(cli_full["periodic"], encoder_results["periodic"]);
  }
  auto bad = api.PostJson("/api/v1/streams/" + std::to_string(id) + "/profile",
                          {{"channel", 1}, {"axis", "X"}, {"error_direction", "Z"}});
  EXPECT_EQ(bad->status, 400);
  EXPECT_EQ(json::parse(bad->body)["field"], "position");
}

#endif  // KM_STREAM_SOAK_ONLY

}  // namespace
