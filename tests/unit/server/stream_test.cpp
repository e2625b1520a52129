// Stream storage: chunk encoding, gap and duplicate handling, restart, downsampling, and the
// stream → straightness profile conversion.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "analysis/core/errors.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "server/streams/stream_chunks.h"
#include "server/streams/streams.h"
#include "usecases/stream_profile.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

ingest::SampleRun MakeRun(std::uint32_t channel, std::uint64_t first, std::size_t n,
                          std::int64_t t0_us, std::int64_t dt_us, std::uint32_t seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  ingest::SampleRun r;
  r.channel = channel;
  r.first_counter = first;
  for (std::size_t k = 0; k < n; ++k) {
    r.t_us.push_back(t0_us + static_cast<std::int64_t>(first + k) * dt_us);
    r.value_um.push_back(std::sin(0.001 * static_cast<double>(first + k)) + 1e-3 * noise(rng));
    r.status.push_back(0);
  }
  return r;
}

bool BitEqual(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

TEST(StreamChunk, RoundTripIsBitExact) {
  auto run = MakeRun(3, 1000, 500, 1'763'700'000'000'000, 50);
  run.t_us[7] -= 3;  // irregular timing survives
  run.t_us[8] = run.t_us[7];
  run.value_um[10] = -0.0;
  run.value_um[11] = 1e-300;
  run.status[42] = 5;
  const auto c = EncodeStreamChunk(run, 100, 400);
  EXPECT_EQ(c.first_counter, 1100);
  EXPECT_EQ(c.n, 300);
  EXPECT_EQ(c.flagged, 0);
  EXPECT_LT(c.data.size(), 300u * 10u + 16u);  // 8-byte values + 1-2 byte time deltas
  const auto back = DecodeStreamChunk(c);
  ASSERT_EQ(back.size(), 300u);
  for (std::size_t i = 0; i < 300; ++i) {
    EXPECT_EQ(back.t_us[i], run.t_us[100 + i]);
    EXPECT_TRUE(BitEqual(back.value_um[i], run.value_um[100 + i]));
    EXPECT_EQ(back.status[i], run.status[100 + i]);
  }
  const auto all = EncodeStreamChunk(run, 0, run.size());
  EXPECT_EQ(all.flagged, 1);
  const auto back_all = DecodeStreamChunk(all);
  EXPECT_EQ(back_all.status[42], 5);
  EXPECT_TRUE(BitEqual(back_all.value_um[10], -0.0));
  double mn = 1e9, mx = -1e9, sum = 0;
  for (double v : run.value_um) {
    mn = std::min(mn, v);
    mx = std::max(mx, v);
    sum += v;
  }
  EXPECT_EQ(all.value_min, mn);
  EXPECT_EQ(all.value_max, mx);
  EXPECT_NEAR(all.value_sum, sum, 1e-12);
}

TEST(StreamChunk, ExtremeTimestampsRoundTrip) {
  ingest::SampleRun r;
  r.t_us = {std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::max(), 0,
            -5};
  r.value_um = {1, 2, 3, 4};
  r.status = {0, 0, 0, 0};
  const auto back = DecodeStreamChunk(EncodeStreamChunk(r, 0, 4));
  EXPECT_EQ(back.t_us, r.t_us);
}

TEST(StreamChunk, DamagedDataIsReportedNotRead) {
  auto c = EncodeStreamChunk(MakeRun(1, 0, 100, 0, 50), 0, 100);
  for (std::size_t cut : {std::size_t{0}, std::size_t{1}, std::size_t{5}, c.data.size() - 1}) {
    StreamChunk d = c;
    d.data.resize(cut);
    EXPECT_THROW(DecodeStreamChunk(d), Error) << cut;
  }
  StreamChunk wrong_n = c;
  wrong_n.n = 99;
  EXPECT_THROW(DecodeStreamChunk(wrong_n), Error);
  StreamChunk extra = c;
  extra.data.push_back('x');
  EXPECT_THROW(DecodeStreamChunk(extra), Error);
}

class StreamHubTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = fs::temp_directory_path() /
            ("km-streams-" + std::to_string(::getpid()) + "-" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db");
    Remove();
  }
  void TearDown() override { Remove(); }
  void Remove() {
    for (const char* ext : {"", "-wal", "-shm"}) fs::remove(path_.string() + ext);
  }
  // All stored samples of a channel, in counter order, with their counters.
  static std::vector<std::pair<std::int64_t, double>> Stored(Storage& st, StreamId id,
                                                             std::int64_t ch) {
    std::vector<std::pair<std::int64_t, double>> out;
    for (const auto& c : st.ReadStreamChunks(id, ch, std::numeric_limits<std::int64_t>::min(),
                                             std::numeric_limits<std::int64_t>::max(), true)) {
      const auto r = DecodeStreamChunk(c);
      for (std::size_t i = 0; i < r.size(); ++i) {
        out.emplace_back(static_cast<std::int64_t>(r.first_counter + i), r.value_um[i]);
      }
    }
    return out;
  }
  fs::path path_;
};

TEST_F(StreamHubTest, GapsDuplicatesAndChunksOfConsecutiveCounters) {
  SqliteStorage st(path_.string());
  StreamOptions opt;
  opt.chunk_samples = 64;
  opt.ready_chunks = 4;
  StreamHub hub(st, opt);
  const auto id = hub.Create({"m1", "run", "http", "{}"});
  IngestCounts counts;
  const auto full = MakeRun(2, 0, 1000, 1'000'000, 50);
  auto slice = [&](std::size_t b, std::size_t e) {
    ingest::SampleRun r;
    r.channel = 2;
    r.first_counter = b;
    r.t_us.assign(full.t_us.begin() + b, full.t_us.begin() + e);
    r.value_um.assign(full.value_um.begin() + b, full.value_um.begin() + e);
    r.status.assign(e - b, 0);
    return r;
  };
  hub.Accept(id, slice(0, 300), counts);
  hub.Accept(id, slice(350, 600), counts);  // 300…349 lost
  hub.Accept(id, slice(500, 700), counts);  // 500…599 resent
  hub.Accept(id, slice(100, 200), counts);  // old, all duplicates
  hub.Accept(id, slice(700, 1000), counts);
  hub.Flush(id);
  EXPECT_EQ(counts.samples, 300u + 250u + 200u + 100u + 300u);
  EXPECT_EQ(counts.accepted, 950u);
  EXPECT_EQ(counts.duplicates, 200u);
  ASSERT_EQ(counts.gaps.size(), 1u);
  EXPECT_EQ(counts.gaps[0].first_missing, 300);
  EXPECT_EQ(counts.gaps[0].missing, 50);
  EXPECT_EQ(counts.gaps[0].t_before_us, full.t_us[299]);
  EXPECT_EQ(counts.gaps[0].t_after_us, full.t_us[350]);

  const auto stored = Stored(st, id, 2);
  ASSERT_EQ(stored.size(), 950u);
  std::size_t k = 0;
  for (std::int64_t c = 0; c < 1000; ++c) {
    if (c >= 300 && c < 350) continue;
    EXPECT_EQ(stored[k].first, c);
    EXPECT_TRUE(BitEqual(stored[k].second, full.value_um[static_cast<std::size_t>(c)]));
    ++k;
  }
  for (const auto& c :
       st.ReadStreamChunks(id, 2, 0, std::numeric_limits<std::int64_t>::max(), false)) {
    EXPECT_LE(c.n, 64);
    // No chunk spans the gap.
    EXPECT_FALSE(c.first_counter < 350 && c.first_counter + c.n > 300) << c.first_counter;
  }
  const auto gaps = st.StreamGaps(id, 10);
  ASSERT_EQ(gaps.size(), 1u);
  EXPECT_EQ(gaps[0].missing, 50);
  const auto chans = st.StreamChannels(id);
  ASSERT_EQ(chans.size(), 1u);
  EXPECT_EQ(chans[0].samples, 950);
  EXPECT_EQ(chans[0].next_counter, 1000u);
  EXPECT_EQ(chans[0].gaps, 1);
  EXPECT_EQ(chans[0].missing, 50);
}

TEST_F(StreamHubTest, NextCounterSurvivesARestartAndSamplesAreImmutable) {
  StreamId id;
  {
    SqliteStorage st(path_.string());
    StreamHub hub(st, StreamOptions{});
    id = hub.Create({"m1", "", "http", R"({"channels": [{"channel": 1}]})"});
    IngestCounts counts;
    hub.Accept(id, MakeRun(1, 0, 500, 0, 50), counts);
    EXPECT_THROW(hub.Accept(id, MakeRun(9, 0, 5, 0, 50), counts), InvalidInput);  // undeclared
  }  // the hub writes its buffer when it stops
  {
    SqliteStorage st(path_.string());
    StreamHub hub(st, StreamOptions{});
    IngestCounts counts;
    hub.Accept(id, MakeRun(1, 400, 200, 0, 50), counts);  // client resends from 400
    EXPECT_EQ(counts.duplicates, 100u);
    EXPECT_EQ(counts.accepted, 100u);
    EXPECT_TRUE(counts.gaps.empty());
    EXPECT_THROW(hub.Accept(id, MakeRun(9, 0, 5, 0, 50), counts), InvalidInput);  // still declared
    hub.Flush(id);
    EXPECT_EQ(Stored(st, id, 1).size(), 600u);
    EXPECT_THROW(hub.Accept(StreamId(id.value() + 100), MakeRun(1, 0, 5, 0, 50), counts), NotFound);
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  EXPECT_NE(sqlite3_exec(db, "UPDATE stream_chunks SET n = 1", nullptr, nullptr, nullptr),
            SQLITE_OK);
  EXPECT_NE(sqlite3_exec(db, "DELETE FROM stream_chunks", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
}

TEST_F(StreamHubTest, SinkFeedsAStreamFromAcquisitionThreads) {
  SqliteStorage st(path_.string());
  StreamOptions opt;
  opt.flush_interval_ms = 20;
  StreamHub hub(st, opt);
  const auto id = hub.Create({"m1", "", "modbus:dev", "{}"});
  auto sink = hub.SinkFor(id);
  std::vector<std::thread> threads;
  for (std::uint32_t ch = 1; ch <= 2; ++ch) {
    threads.emplace_back([&, ch] {
      for (std::uint64_t k = 0; k < 300; ++k) {
        if (ch == 2 && k >= 100 && k < 110) continue;  // missed polls
        sink->Deliver(
            {ingest::StreamSample{ch, k, static_cast<std::int64_t>(k * 1000), 0.5 * k, 0}});
      }
    });
  }
  for (auto& t : threads) t.join();
  // The background flusher writes without an explicit Flush.
  for (int i = 0; i < 200 && Stored(st, id, 2).size() < 290; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(Stored(st, id, 1).size(), 300u);
  EXPECT_EQ(Stored(st, id, 2).size(), 290u);
  const auto gaps = st.StreamGaps(id, 10);
  ASSERT_EQ(gaps.size(), 1u);
  EXPECT_EQ(gaps[0].channel, 2);
  EXPECT_EQ(gaps[0].first_missing, 100);
  EXPECT_EQ(gaps[0].missing, 10);
}

TEST_F(StreamHubTest, DownsampledBucketsMatchABruteForceOverTheSamples) {
  SqliteStorage st(path_.string());
  StreamHub hub(st, StreamOptions{});
  const auto id = hub.Create({"m1", "", "http", "{}"});
  IngestCounts counts;
  const auto run = MakeRun(1, 0, 20000, 5'000'000, 50, 7);
  hub.Accept(id, run, counts);
  hub.Flush(id);
  const std::int64_t from = run.t_us[1234], to = run.t_us[17000];
  const auto raw = StreamSamplesJson(st, id, 1, from, to, 100000);
  ASSERT_FALSE(raw["downsampled"].get<bool>());
  ASSERT_EQ(raw["t_us"].size(), 17000u - 1234u);
  EXPECT_EQ(raw["counter"][0].get<std::int64_t>(), 1234);
  EXPECT_TRUE(BitEqual(raw["value_um"][5].get<double>(), run.value_um[1239]));

  const std::size_t buckets = 100;
  const auto ds = StreamSamplesJson(st, id, 1, from, to, buckets);
  ASSERT_TRUE(ds["downsampled"].get<bool>());
  ASSERT_EQ(ds["t_us"].size(), buckets);
  // Brute force: the same equal-time buckets over the samples in range.
  const double lo = static_cast<double>(from), hi = static_cast<double>(run.t_us[16999] + 1);
  const double w = (hi - lo) / buckets;
  std::int64_t total = 0;
  for (std::size_t b = 0; b < buckets; ++b) {
    double mn = 1e300, mx = -1e300, sum = 0;
    std::int64_t n = 0;
    for (std::size_t i = 1234; i < 17000; ++i) {
      const auto bi = std::min<std::size_t>(
          buckets - 1, static_cast<std::size_t>((static_cast<double>(run.t_us[i]) - lo) / w));
      if (bi != b) continue;
      mn = std::min(mn, run.value_um[i]);
      mx = std::max(mx, run.value_um[i]);
      sum += run.value_um[i];
      ++n;
    }
    EXPECT_EQ(ds["count"][b].get<std::int64_t>(), n);
    EXPECT_EQ(ds["min_um"][b].get<double>(), mn);
    EXPECT_EQ(ds["max_um"][b].get<double>(), mx);
    EXPECT_NEAR(ds["mean_um"][b].get<double>(), sum / static_cast<double>(n), 1e-12);
    total += n;
  }
  EXPECT_EQ(total, 17000 - 1234);
  EXPECT_THROW(StreamSamplesJson(st, StreamId(id.value() + 1), 1, from, to, 10), NotFound);
  EXPECT_THROW(StreamSamplesJson(st, id, 1, to, from, 10), InvalidInput);
}

// Long streams: whole chunks inside one bucket enter with their stored statistics; the buckets
// must equal those computed from every sample.
TEST_F(StreamHubTest, LongStreamBucketsFromChunkStatisticsEqualTheSamples) {
  SqliteStorage st(path_.string());
  StreamOptions opt;
  opt.chunk_samples = 300;
  StreamHub hub(st, opt);
  const auto id = hub.Create({"m1", "", "modbus:dev", "{}"});
  IngestCounts counts;
  const auto run = MakeRun(4, 0, 400000, 0, 10, 9);
  hub.Accept(id, run, counts);
  hub.Flush(id);
  for (const std::size_t buckets : {std::size_t{97}, std::size_t{1000}}) {
    const std::int64_t from = run.t_us[777], to = run.t_us[399000];
    const auto ds = StreamSamplesJson(st, id, 4, from, to, buckets);
    ASSERT_TRUE(ds["downsampled"].get<bool>());
    ASSERT_EQ(ds["samples_in_range"].get<std::int64_t>(), 399000 - 777);
    const double lo = static_cast<double>(from), hi = static_cast<double>(run.t_us[398999] + 1);
    const double w = (hi - lo) / static_cast<double>(buckets);
    std::vector<double> mn(buckets, 1e300), mx(buckets, -1e300), sum(buckets, 0.0);
    std::vector<std::int64_t> n(buckets, 0);
    for (std::size_t i = 777; i < 399000; ++i) {
      const auto b = std::min<std::size_t>(
          buckets - 1, static_cast<std::size_t>((static_cast<double>(run.t_us[i]) - lo) / w));
      mn[b] = std::min(mn[b], run.value_um[i]);
      mx[b] = std::max(mx[b], run.value_um[i]);
      sum[b] += run.value_um[i];
      ++n[b];
    }
    ASSERT_EQ(ds["count"].size(), buckets);
    for (std::size_t b = 0; b < buckets; ++b) {
      EXPECT_EQ(ds["count"][b].get<std::int64_t>(), n[b]);
      EXPECT_EQ(ds["min_um"][b].get<double>(), mn[b]);
      EXPECT_EQ(ds["max_um"][b].get<double>(), mx[b]);
      EXPECT_NEAR(ds["mean_um"][b].get<double>(), sum[b] / static_cast<double>(n[b]), 1e-12);
    }
  }
  // Asking for every sample of a long range still gives every sample, in counter order.
  const auto raw = StreamSamplesJson(st, id, 4, run.t_us[1000], run.t_us[251000], 300000);
  ASSERT_FALSE(raw["downsampled"].get<bool>());
  ASSERT_EQ(raw["counter"].size(), 250000u);
  for (std::size_t i = 0; i < 250000; i += 4999) {
    EXPECT_EQ(raw["counter"][i].get<std::int64_t>(), static_cast<std::int64_t>(1000 + i));
    EXPECT_TRUE(BitEqual(raw["value_um"][i].get<double>(), run.value_um[1000 + i]));
  }
}

TEST(StreamProfile, FeedTimesTimeAndEncoderPositionsBinToTheTrueProfile) {
  // 20 kHz over 10 s at 600 mm/min: 100 mm of travel; true straightness f(x) known.
  const auto f = [](double x) { return 0.2 * std::sin(2 * M_PI * x / 55.0) + 0.001 * x; };
  std::vector<std::int64_t> t;
  std::vector<double> dev, enc_um;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (std::int64_t k = 0; k < 200000; ++k) {
    t.push_back(1'000'000 + k * 50);
    const double x = 10.0 + 600.0 / 60.0 * (k * 50) * 1e-6;
    dev.push_back(f(x) + noise(rng));
    enc_um.push_back(x * 1000.0);
  }
  const auto x_feed = usecases::FeedPositionMm(t, 10.0, 600.0);
  EXPECT_NEAR(x_feed.back(), 10.0 + 10.0 * (199999.0 / 200000.0) * 10.0, 1e-9);
  const auto x_enc = usecases::InterpolatePositionMm(t, enc_um, t);
  for (std::size_t i = 0; i < t.size(); i += 997) EXPECT_NEAR(x_enc[i], x_feed[i], 1e-9);
  // Encoder sampled at a quarter of the rate, offset in time: interpolation is exact for
  // linear motion, and samples outside its span are dropped (NaN).
  std::vector<std::int64_t> te;
  std::vector<double> ve;
  for (std::size_t i = 3; i < t.size(); i += 4) {
    te.push_back(t[i] + 10);
    ve.push_back(enc_um[i] + 10 * 1e-6 * 10.0 * 1000.0);
  }
  const auto x_sparse = usecases::InterpolatePositionMm(te, ve, t);
  EXPECT_TRUE(std::isnan(x_sparse[0]));
  for (std::size_t i = 4; i + 4 < t.size(); i += 1013) EXPECT_NEAR(x_sparse[i], x_feed[i], 1e-9);

  const auto p = usecases::BinProfile(x_feed, dev, 500);
  ASSERT_EQ(p.position_mm.size(), 500u);
  for (std::size_t i = 1; i < p.position_mm.size(); ++i) {
    ASSERT_GT(p.position_mm[i], p.position_mm[i - 1]);
  }
  // 400 samples a bin: noise 0.02/√400 = 0.001 µm; the bin mean of f differs from f(mean x)
  // by f''·w²/24 ≈ 3e-5 µm.
  for (std::size_t i = 0; i < p.position_mm.size(); ++i) {
    EXPECT_NEAR(p.deviation_um[i], f(p.position_mm[i]), 0.005);
  }
  // Reverse travel gives the same increasing profile.
  auto x_rev = usecases::FeedPositionMm(t, 110.0, -600.0);
  const auto q = usecases::BinProfile(x_rev, dev, 100);
  ASSERT_EQ(q.position_mm.size(), 100u);
  EXPECT_LT(q.position_mm.front(), q.position_mm.back());
  EXPECT_THROW(usecases::BinProfile(std::vector<double>(10, 1.0), std::vector<double>(10, 0.0), 10),
               InvalidInput);
}

}  // namespace
}  // namespace km::server
