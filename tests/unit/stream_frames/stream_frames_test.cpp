#include "ingest/stream_frames.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "tests/unit/stream_frames/stream_frames_test_util.h"

namespace km::ingest {
namespace {

using test::RandomRun;
using test::RawFrame;
using test::SameRun;
using test::UniformT;

std::vector<SampleRun> DecodeAll(FrameFormat format, const std::string& bytes,
                                 std::vector<std::size_t> cuts = {}) {
  StreamFrameDecoder dec(format, "upload");
  std::vector<SampleRun> runs;
  auto sink = [&](SampleRun&& r) { runs.push_back(std::move(r)); };
  std::size_t at = 0;
  cuts.push_back(bytes.size());
  for (std::size_t c : cuts) {
    dec.Feed(std::string_view(bytes).substr(at, c - at), sink);
    at = c;
  }
  dec.Finish();
  EXPECT_EQ(dec.frames(), runs.size());
  EXPECT_EQ(dec.bytes(), bytes.size());
  return runs;
}

struct Failure {
  InvalidInput error{""};
  std::vector<SampleRun> delivered;
};

// Decodes and expects an InvalidInput; returns it with the runs delivered
// before it.
Failure DecodeExpectingError(FrameFormat format, const std::string& bytes,
                             std::size_t limit = kFrameMaxSamples, bool finish = true) {
  StreamFrameDecoder dec(format, "upload", limit);
  Failure f;
  try {
    dec.Feed(bytes, [&](SampleRun&& r) { f.delivered.push_back(std::move(r)); });
    if (finish) dec.Finish();
  } catch (const InvalidInput& e) {
    f.error = e;
    // The decoder is unusable afterwards.
    EXPECT_THROW(dec.Feed("x", [](SampleRun&&) {}), InvalidInput);
    return f;
  }
  ADD_FAILURE() << "no InvalidInput for input of " << bytes.size() << " bytes";
  return f;
}

RawFrame ValidRaw(std::uint32_t n = 3) {
  RawFrame f;
  f.channel = 7;
  f.n = n;
  f.first_counter = 100;
  f.t0_us = 1763700000000000;
  f.dt_ns = 50000;
  for (std::uint32_t k = 0; k < n; ++k) f.values.push_back(0.25 * k - 1.0);
  return f;
}

// ------------------------------------------------------------------------------------------
// Content type

TEST(StreamFrames, ContentType) {
  EXPECT_EQ(FrameFormatFromContentType("application/vnd.kinemetric.stream-frame"),
            FrameFormat::kBinary);
  EXPECT_EQ(FrameFormatFromContentType(" Application/X-NDJSON ; charset=utf-8"),
            FrameFormat::kNdjson);
  try {
    FrameFormatFromContentType("application/json");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "Content-Type");
  }
  EXPECT_THROW(FrameFormatFromContentType(""), InvalidInput);
}

// ------------------------------------------------------------------------------------------
// Binary

TEST(StreamFrames, HandBuiltBinaryFrameDecodesPerSpec) {
  // Built byte by byte from the description (not with the product's encoder).
  RawFrame f = ValidRaw(4);
  f.dt_ns = 33333;  // 33.333 µs: t_k = t0 + (k·33333 + 500)/1000 = t0 + 0, 33, 67, 100
  const auto runs = DecodeAll(FrameFormat::kBinary, f.Bytes());
  ASSERT_EQ(runs.size(), 1u);
  const SampleRun& r = runs[0];
  EXPECT_EQ(r.channel, 7u);
  EXPECT_EQ(r.first_counter, 100u);
  EXPECT_EQ(r.t_us,
            (std::vector<std::int64_t>{f.t0_us, f.t0_us + 33, f.t0_us + 67, f.t0_us + 100}));
  EXPECT_EQ(r.value_um, f.values);
  EXPECT_EQ(r.status, std::vector<std::uint8_t>(4, 0));

  // With both optional blocks (timestamps, then status).
  RawFrame g = ValidRaw(3);
  g.flags = kFrameFlagStatus | kFrameFlagTimestamps;
  g.dt_ns = 0;
  g.times = {g.t0_us, g.t0_us - 5, g.t0_us + 1000000};
  g.status = {0, 3, 255};
  const auto runs2 = DecodeAll(FrameFormat::kBinary, g.Bytes());
  ASSERT_EQ(runs2.size(), 1u);
  EXPECT_EQ(runs2[0].t_us, g.times);
  EXPECT_EQ(runs2[0].status, g.status);
  // The product's encoder writes exactly these bytes.
  EXPECT_EQ(EncodeBinaryFrame(runs2[0], true, true, 0), g.Bytes());
  EXPECT_EQ(EncodeBinaryFrame(runs[0], false, false, 33333), f.Bytes());
}

TEST(StreamFrames, BinaryRoundTripAllFlagCombinations) {
  for (unsigned seed : {11u, 12u, 13u}) {
    std::mt19937 rng(seed);
    for (int flags = 0; flags < 4; ++flags) {
      const bool with_status = flags & 1, with_times = flags & 2;
      for (std::size_t n : {1u, 2u, 999u, 1000u}) {
        for (std::uint32_t dt_ns : {1u, 20000u, 33333u, 4294967295u}) {
          const SampleRun run = RandomRun(rng, n, dt_ns, with_times, with_status);
          const std::string bytes = EncodeBinaryFrame(run, with_times, with_status, dt_ns);
          EXPECT_EQ(bytes.size(), 32 + n * (8 + (with_times ? 8 : 0) + (with_status ? 1 : 0)) + 4);
          const auto out = DecodeAll(FrameFormat::kBinary, bytes);
          ASSERT_EQ(out.size(), 1u);
          ASSERT_TRUE(SameRun(out[0], run)) << "seed " << seed << " flags " << flags << " n " << n;
        }
      }
    }
  }
}

TEST(StreamFrames, BinaryMaximumFrame) {
  std::mt19937 rng(14);
  const SampleRun run = RandomRun(rng, kFrameMaxSamples, 1000, false, true);
  const auto out = DecodeAll(FrameFormat::kBinary, EncodeBinaryFrame(run, false, true, 1000));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(SameRun(out[0], run));
  SampleRun too_big = run;
  too_big.value_um.push_back(1.0);
  too_big.t_us.push_back(too_big.t_us.back() + 1);
  too_big.status.push_back(0);
  EXPECT_THROW(EncodeBinaryFrame(too_big, true, true, 0), std::invalid_argument);
}

TEST(StreamFrames, DoublesRoundTripBitExactly) {
  const std::vector<double> special = {0.0,
                                       -0.0,
                                       0.1,
                                       -1.0 / 3.0,
                                       std::numeric_limits<double>::min(),
                                       std::numeric_limits<double>::denorm_min(),
                                       -std::numeric_limits<double>::denorm_min(),
                                       std::numeric_limits<double>::max(),
                                       -std::numeric_limits<double>::max(),
                                       std::nextafter(1.0, 2.0),
                                       123456.78901234567};
  SampleRun run;
  run.channel = 65535;
  run.first_counter = kMaxStreamCounter - (special.size() - 1);  // ends on the last counter
  for (std::size_t k = 0; k < special.size(); ++k) {
    run.value_um.push_back(special[k]);
    run.t_us.push_back(-5 + static_cast<std::int64_t>(k));
    run.status.push_back(0);
  }
  const auto bin = DecodeAll(FrameFormat::kBinary, EncodeBinaryFrame(run, true, false, 0));
  ASSERT_EQ(bin.size(), 1u);
  EXPECT_TRUE(SameRun(bin[0], run));
  const auto nd = DecodeAll(FrameFormat::kNdjson, EncodeNdjsonRun(run));
  ASSERT_EQ(nd.size(), 1u);
  EXPECT_TRUE(SameRun(nd[0], run));
  EXPECT_TRUE(std::signbit(nd[0].value_um[1]));
  // Random doubles over the whole exponent range.
  for (unsigned seed : {15u, 16u}) {
    std::mt19937_64 rng(seed);
    SampleRun r;
    r.channel = 1;
    for (int k = 0; k < 2000; ++k) {
      double v;
      do {
        const std::uint64_t bits = rng();
        std::memcpy(&v, &bits, 8);
      } while (!std::isfinite(v));
      r.value_um.push_back(v);
      r.t_us.push_back(k);
      r.status.push_back(0);
    }
    const auto b = DecodeAll(FrameFormat::kBinary, EncodeBinaryFrame(r, false, false, 1000));
    const auto j = DecodeAll(FrameFormat::kNdjson, EncodeNdjsonRun(r));
    ASSERT_EQ(b.size(), 1u);
    ASSERT_EQ(j.size(), 1u);
    EXPECT_TRUE(SameRun(b[0], r));
    EXPECT_TRUE(SameRun(j[0], r));
  }
}

TEST(StreamFrames, EncoderChecksUniformTimestamps) {
  std::mt19937 rng(17);
  SampleRun run = RandomRun(rng, 10, 33333, false, false);
  EXPECT_NO_THROW(EncodeBinaryFrame(run, false, false, 33333));
  EXPECT_THROW(EncodeBinaryFrame(run, false, false, 33400), std::invalid_argument);
  EXPECT_THROW(EncodeBinaryFrame(run, false, false, 0), std::invalid_argument);
  run.t_us[9] += 1;
  EXPECT_THROW(EncodeBinaryFrame(run, false, false, 33333), std::invalid_argument);
  EXPECT_NO_THROW(EncodeBinaryFrame(run, true, false, 0));
  run.status[3] = 1;
  EXPECT_THROW(EncodeBinaryFrame(run, true, false, 0), std::invalid_argument);
  run.value_um[2] = std::nan("");
  EXPECT_THROW(EncodeBinaryFrame(run, true, true, 0), std::invalid_argument);
  EXPECT_THROW(EncodeNdjsonRun(run), std::invalid_argument);
  SampleRun empty;
  EXPECT_THROW(EncodeBinaryFrame(empty, true, true, 0), std::invalid_argument);
}

std::string ThreeFrames(std::mt19937& rng, std::vector<SampleRun>* runs) {
  std::string bytes;
  runs->push_back(RandomRun(rng, 5, 20000, false, false));
  bytes += EncodeBinaryFrame(runs->back(), false, false, 20000);
  runs->push_back(RandomRun(rng, 3, 0, true, true));
  bytes += EncodeBinaryFrame(runs->back(), true, true, 0);
  runs->push_back(RandomRun(rng, 4, 1000, false, true));
  bytes += EncodeBinaryFrame(runs->back(), false, true, 1000);
  return bytes;
}

TEST(StreamFrames, BinarySplitAtEveryByteBoundary) {
  std::mt19937 rng(21);
  std::vector<SampleRun> runs;
  const std::string bytes = ThreeFrames(rng, &runs);
  for (std::size_t i = 0; i <= bytes.size(); ++i) {
    const auto out = DecodeAll(FrameFormat::kBinary, bytes, {i});
    ASSERT_EQ(out.size(), 3u) << "split at " << i;
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(SameRun(out[k], runs[k])) << "split at " << i;
  }
  // Two cuts everywhere in the first two frames, and one byte at a time.
  for (std::size_t i = 0; i < 120; ++i) {
    for (std::size_t j = i; j < 140; j += 3) {
      const auto out = DecodeAll(FrameFormat::kBinary, bytes, {i, j});
      ASSERT_EQ(out.size(), 3u);
      ASSERT_TRUE(SameRun(out[1], runs[1]));
    }
  }
  std::vector<std::size_t> every(bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) every[i] = i;
  const auto out = DecodeAll(FrameFormat::kBinary, bytes, every);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_TRUE(SameRun(out[2], runs[2]));
}

TEST(StreamFrames, BinaryCounters) {
  std::mt19937 rng(22);
  std::vector<SampleRun> runs;
  const std::string bytes = ThreeFrames(rng, &runs);
  StreamFrameDecoder dec(FrameFormat::kBinary, "s");
  std::size_t got = 0;
  dec.Feed(bytes.substr(0, 50), [&](SampleRun&&) { ++got; });
  EXPECT_EQ(got, 0u);  // first frame is 32 + 40 + 4 bytes
  dec.Feed(bytes.substr(50), [&](SampleRun&&) { ++got; });
  dec.Finish();
  EXPECT_EQ(got, 3u);
  EXPECT_EQ(dec.frames(), 3u);
  EXPECT_EQ(dec.samples(), 12u);
  EXPECT_EQ(dec.bytes(), bytes.size());
}

void ExpectBinaryError(const std::string& bytes, std::size_t frame, const std::string& field,
                       std::size_t delivered_before, std::size_t offset,
                       std::size_t limit = kFrameMaxSamples) {
  const Failure f = DecodeExpectingError(FrameFormat::kBinary, bytes, limit);
  EXPECT_EQ(f.error.file(), "upload");
  EXPECT_EQ(f.error.line(), frame) << f.error.what();
  EXPECT_EQ(f.error.field(), field) << f.error.what();
  EXPECT_NE(f.error.reason().find("byte offset " + std::to_string(offset)), std::string::npos)
      << f.error.what();
  EXPECT_EQ(f.delivered.size(), delivered_before);
}

TEST(StreamFrames, BinaryErrorsNameFrameOffsetAndField) {
  const std::string good = ValidRaw().Bytes();  // 32 + 24 + 4 = 60 bytes
  ASSERT_EQ(good.size(), 60u);
  auto second = [&](const RawFrame& bad) { return good + bad.Bytes(); };
  RawFrame f;

  f = ValidRaw();
  f.magic = "KMSG";
  ExpectBinaryError(second(f), 2, "magic", 1, 60);
  ExpectBinaryError(good + "{\"channel\":1}\n", 2, "magic", 1, 60);
  ExpectBinaryError(good + "K", 2, "header", 1,
                    60);  // truncated, detected by Finish
  ExpectBinaryError(good + "KX", 2, "magic", 1,
                    60);  // wrong even before a whole header

  f = ValidRaw();
  f.version = 2;
  ExpectBinaryError(second(f), 2, "version", 1, 60);

  f = ValidRaw();
  f.flags = 4;
  ExpectBinaryError(second(f), 2, "flags", 1, 60);

  f = ValidRaw();
  f.n = 0;
  f.values.clear();
  ExpectBinaryError(second(f), 2, "n", 1, 60);

  f = ValidRaw();
  f.n = 65537;  // refused from the header alone, the payload is never awaited
  ExpectBinaryError(good + f.Bytes().substr(0, 32), 2, "n", 1, 60);

  // Larger than the decoder's limit: TooLarge, again from the header.
  {
    RawFrame big = ValidRaw(11);
    const Failure fl = DecodeExpectingError(FrameFormat::kBinary, big.Bytes().substr(0, 32), 10);
    EXPECT_EQ(fl.error.field(), "n");
    EXPECT_NE(fl.error.reason().find("limit of 10"), std::string::npos);
    StreamFrameDecoder dec(FrameFormat::kBinary, "u", 10);
    EXPECT_THROW(dec.Feed(big.Bytes(), [](SampleRun&&) {}), TooLarge);
  }

  f = ValidRaw();
  f.dt_ns = 0;
  ExpectBinaryError(second(f), 2, "dt_ns", 1, 60);

  f = ValidRaw();
  f.first_counter = std::numeric_limits<std::uint64_t>::max() - 1;  // n = 3 overflows
  ExpectBinaryError(second(f), 2, "first_counter", 1, 60);

  f = ValidRaw();
  f.t0_us = std::numeric_limits<std::int64_t>::max() - 50;  // t_2 = t0 + 100 overflows
  ExpectBinaryError(second(f), 2, "t0_us", 1, 60);

  f = ValidRaw();
  f.values[1] = std::numeric_limits<double>::infinity();
  ExpectBinaryError(second(f), 2, "value_um", 1, 60);
  f.values[1] = std::nan("");
  ExpectBinaryError(good + good + f.Bytes(), 3, "value_um", 2, 120);

  f = ValidRaw();
  f.flags = kFrameFlagTimestamps;
  f.times = {f.t0_us + 1, f.t0_us + 2, f.t0_us + 3};  // t0_us must be the time of sample 0
  ExpectBinaryError(second(f), 2, "t0_us", 1, 60);

  std::string bad_crc = good + good;
  bad_crc[60 + 40] ^= 0x01;  // a flipped payload bit
  ExpectBinaryError(bad_crc, 2, "crc32", 1, 60);
  bad_crc = good + good;
  bad_crc[119] ^= 0x80;  // a flipped CRC bit
  ExpectBinaryError(bad_crc, 2, "crc32", 1, 60);
}

TEST(StreamFrames, BinaryTruncationReportedByFinish) {
  const std::string good = ValidRaw().Bytes();
  for (std::size_t cut = 1; cut < good.size(); ++cut) {
    const Failure f = DecodeExpectingError(FrameFormat::kBinary, good + good.substr(0, cut));
    EXPECT_EQ(f.error.line(), 2u);
    EXPECT_EQ(f.error.field(), cut < 32 ? "header" : "payload") << cut;
    EXPECT_NE(f.error.reason().find("truncated"), std::string::npos);
    EXPECT_EQ(f.delivered.size(), 1u);
  }
  // Nothing pending: Finish succeeds, also on empty input.
  EXPECT_TRUE(DecodeAll(FrameFormat::kBinary, "").empty());
}

TEST(StreamFrames, ErrorInCallbackStopsDecoder) {
  const std::string good = ValidRaw().Bytes();
  StreamFrameDecoder dec(FrameFormat::kBinary, "u");
  EXPECT_THROW(dec.Feed(good, [](SampleRun&&) { throw std::runtime_error("sink full"); }),
               std::runtime_error);
  EXPECT_THROW(dec.Feed(good, [](SampleRun&&) {}), InvalidInput);
  EXPECT_THROW(dec.Finish(), InvalidInput);
  EXPECT_THROW(StreamFrameDecoder(FrameFormat::kBinary, "u", 0), std::invalid_argument);
}

// ------------------------------------------------------------------------------------------
// NDJSON

TEST(StreamFrames, NdjsonSampleAndRunShapes) {
  const std::string text =
      "{\"channel\":1,\"counter\":42,\"t_us\":1763700000000000,\"value_um\":0."
      "123,\"status\":0}\n"
      "\r\n"
      "   \n"
      "{\"channel\":2,\"counter\":-0,\"t_us\":-3,\"value_um\":-5}\r\n"
      "{\"channel\":1,\"first_counter\":43,\"t0_us\":1763700000000050,\"dt_"
      "us\":50,"
      "\"values_um\":[1.5,2.5,3],\"status\":[0,4,0]}\n"
      "{\"values_um\":[7],\"t_us\":[99],\"first_counter\":0,\"channel\":65535}"
      "\n";
  const auto runs = DecodeAll(FrameFormat::kNdjson, text);
  ASSERT_EQ(runs.size(), 4u);
  EXPECT_EQ(runs[0].channel, 1u);
  EXPECT_EQ(runs[0].first_counter, 42u);
  EXPECT_EQ(runs[0].t_us, std::vector<std::int64_t>{1763700000000000});
  EXPECT_EQ(runs[0].value_um, std::vector<double>{0.123});
  EXPECT_EQ(runs[1].status, std::vector<std::uint8_t>{0});
  EXPECT_EQ(runs[1].t_us, std::vector<std::int64_t>{-3});
  EXPECT_EQ(runs[1].first_counter, 0u);  // "-0" is 0
  EXPECT_EQ(runs[2].first_counter, 43u);
  EXPECT_EQ(runs[2].t_us,
            (std::vector<std::int64_t>{1763700000000050, 1763700000000100, 1763700000000150}));
  EXPECT_EQ(runs[2].value_um, (std::vector<double>{1.5, 2.5, 3.0}));
  EXPECT_EQ(runs[2].status, (std::vector<std::uint8_t>{0, 4, 0}));
  EXPECT_EQ(runs[3].channel, 65535u);
  EXPECT_EQ(runs[3].t_us, std::vector<std::int64_t>{99});
  EXPECT_EQ(runs[3].status, std::vector<std::uint8_t>{0});
}

TEST(StreamFrames, NdjsonFractionalPeriod) {
  // dt = 100/3 µs: t_k = t0 + llround(k·100/3), independently (200k + 3) / 6 in
  // integers.
  std::string line =
      "{\"channel\":3,\"first_counter\":0,\"t0_us\":1000,\"dt_"
      "us\":33.333333333333336,"
      "\"values_um\":[";
  const int n = 3001;
  for (int k = 0; k < n; ++k) line += (k ? ",0" : "0");
  line += "]}\n";
  const auto runs = DecodeAll(FrameFormat::kNdjson, line);
  ASSERT_EQ(runs.size(), 1u);
  ASSERT_EQ(runs[0].size(), static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    ASSERT_EQ(runs[0].t_us[k], 1000 + (200 * k + 3) / 6) << k;
  }
}

TEST(StreamFrames, NdjsonRoundTrip) {
  for (unsigned seed : {31u, 32u, 33u}) {
    std::mt19937 rng(seed);
    std::string text;
    std::vector<SampleRun> expected;
    for (int i = 0; i < 6; ++i) {
      expected.push_back(RandomRun(rng, 1 + 97 * i, 0, true, i % 2 == 1));
      text += EncodeNdjsonRun(expected.back());
    }
    StreamSample s{9, 123456789012345ull, -77, 1.0 / 7.0, 200};
    text += EncodeNdjsonSample(s);
    const auto runs = DecodeAll(FrameFormat::kNdjson, text);
    ASSERT_EQ(runs.size(), expected.size() + 1);
    for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_TRUE(SameRun(runs[i], expected[i]));
    const SampleRun& last = runs.back();
    EXPECT_EQ(last.channel, s.channel);
    EXPECT_EQ(last.first_counter, s.counter);
    EXPECT_EQ(last.t_us[0], s.t_us);
    EXPECT_EQ(last.value_um[0], s.value_um);
    EXPECT_EQ(last.status[0], s.status);
    EXPECT_EQ(text.back(), '\n');
  }
  // Only a status that carries information is written.
  SampleRun quiet;
  quiet.value_um = {1.0};
  quiet.t_us = {5};
  quiet.status = {0};
  EXPECT_EQ(EncodeNdjsonRun(quiet),
            "{\"channel\":0,\"first_counter\":0,\"t_us\":[5],\"values_um\":[1.0]}\n");
}

TEST(StreamFrames, NdjsonSplitAtEveryByteBoundary) {
  std::mt19937 rng(34);
  std::vector<SampleRun> expected;
  std::string text;
  for (int i = 0; i < 3; ++i) {
    expected.push_back(RandomRun(rng, 3, 0, true, true));
    text += EncodeNdjsonRun(expected.back());
    if (i == 1) text.insert(text.size() - 1, "\r");  // one CRLF line
    text += "\n";                                    // blank lines in between
  }
  for (std::size_t i = 0; i <= text.size(); ++i) {
    const auto out = DecodeAll(FrameFormat::kNdjson, text, {i});
    ASSERT_EQ(out.size(), 3u) << i;
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(SameRun(out[k], expected[k])) << i;
  }
  std::vector<std::size_t> every(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) every[i] = i;
  EXPECT_EQ(DecodeAll(FrameFormat::kNdjson, text, every).size(), 3u);
}

void ExpectLineError(const std::string& text, std::size_t line, const std::string& field,
                     std::size_t delivered_before, std::size_t limit = kFrameMaxSamples) {
  const Failure f = DecodeExpectingError(FrameFormat::kNdjson, text, limit);
  EXPECT_EQ(f.error.file(), "upload");
  EXPECT_EQ(f.error.line(), line) << text << " → " << f.error.what();
  EXPECT_EQ(f.error.field(), field) << text << " → " << f.error.what();
  EXPECT_EQ(f.delivered.size(), delivered_before) << text;
}

// Counters are 0 … 2⁶³ − 1 in both formats (docs/streams.md, Counter range): a frame or run
// ending on 2⁶³ − 1 is read, one passing it is refused naming the counter field.
TEST(StreamFrames, CountersStopAtTwoToTheSixtyThreeMinusOne) {
  constexpr std::uint64_t kLast = 9223372036854775807ULL;
  static_assert(kMaxStreamCounter == kLast);
  SampleRun run;
  run.channel = 1;
  run.value_um = {0.5, 0.25, 0.125};
  run.t_us = {1, 2, 3};
  run.status = {0, 0, 0};
  for (const std::uint64_t first :
       std::initializer_list<std::uint64_t>{kLast - 2, kLast - 1, kLast, kLast + 1, ~0ULL - 2}) {
    run.first_counter = first;
    const bool fits = first <= kLast - 2;
    for (const auto format : {FrameFormat::kBinary, FrameFormat::kNdjson}) {
      const std::string bytes = format == FrameFormat::kBinary
                                    ? EncodeBinaryFrame(run, true, false, 0)
                                    : EncodeNdjsonRun(run);
      if (fits) {
        const auto runs = DecodeAll(format, bytes);
        ASSERT_EQ(runs.size(), 1u);
        EXPECT_EQ(runs[0].first_counter, first);
        continue;
      }
      try {
        DecodeAll(format, bytes);
        ADD_FAILURE() << "accepted first counter " << first;
      } catch (const InvalidInput& e) {
        EXPECT_EQ(e.field(), "first_counter") << e.what();
        EXPECT_NE(e.reason().find("9223372036854775807"), std::string::npos) << e.reason();
      }
    }
  }
  const std::string last =
      "{\"channel\":1,\"counter\":9223372036854775807,\"t_us\":1,\"value_um\":1}\n";
  ASSERT_EQ(DecodeAll(FrameFormat::kNdjson, last).size(), 1u);
  EXPECT_EQ(DecodeAll(FrameFormat::kNdjson, last)[0].first_counter, kLast);
}

TEST(StreamFrames, NdjsonErrorsNameLineAndField) {
  // Two good lines and a blank one first: errors are on line 4.
  const std::string ok =
      "{\"channel\":1,\"counter\":1,\"t_us\":10,\"value_um\":0.5}\n\n"
      "{\"channel\":1,\"counter\":2,\"t_us\":20,\"value_um\":0.5}\r\n";
  auto bad = [&](const std::string& line, const std::string& field, std::size_t limit = 65536) {
    ExpectLineError(ok + line + "\n", 4, field, 2, limit);
  };
  const std::string s = "\"channel\":1,\"counter\":3,\"t_us\":30";  // sample line without value
  bad("{" + s + ",\"value_um\":0.5", "json");
  bad("not json", "json");
  bad("[1,2]", "json");
  bad("{" + s + "}", "value_um");
  bad("{" + s + ",\"value_um\":\"0.5\"}", "value_um");
  bad("{" + s + ",\"value_um\":null}", "value_um");
  bad("{" + s + ",\"value_um\":0.5,\"vaule_um\":1}", "vaule_um");
  bad("{" + s + ",\"value_um\":0.5,\"value_um\":1}", "value_um");  // repeated key
  bad("{" + s + ",\"value_um\":0.5,\"\":1}", "json");              // empty key
  bad("{" + s + ",\"value_um\":0.5,\"status\":256}", "status");
  bad("{" + s + ",\"value_um\":0.5,\"status\":-1}", "status");
  bad("{" + s + ",\"value_um\":0.5,\"first_counter\":3}", "first_counter");
  bad("{\"channel\":65536,\"counter\":3,\"t_us\":30,\"value_um\":1}", "channel");
  bad("{\"channel\":-1,\"counter\":3,\"t_us\":30,\"value_um\":1}", "channel");
  bad("{\"channel\":1.0,\"counter\":3,\"t_us\":30,\"value_um\":1}", "channel");
  bad("{\"counter\":3,\"t_us\":30,\"value_um\":1}", "channel");
  bad("{\"channel\":1,\"counter\":-3,\"t_us\":30,\"value_um\":1}", "counter");
  bad("{\"channel\":1,\"counter\":3.5,\"t_us\":30,\"value_um\":1}", "counter");
  bad("{\"channel\":1,\"t_us\":30,\"value_um\":1}", "counter");
  bad("{\"channel\":1,\"counter\":3,\"t_us\":30.5,\"value_um\":1}", "t_us");
  bad("{\"channel\":1,\"counter\":3,\"t_us\":9223372036854775808,\"value_um\":"
      "1}",
      "t_us");
  bad("{\"channel\":1,\"counter\":3,\"value_um\":1}", "t_us");

  const std::string r = "\"channel\":1,\"first_counter\":5,";
  bad("{" + r + "\"t0_us\":0,\"dt_us\":50,\"values_um\":[]}", "values_um");
  bad("{" + r + "\"t0_us\":0,\"dt_us\":50,\"values_um\":3}", "values_um");
  bad("{" + r + "\"t0_us\":0,\"dt_us\":50,\"values_um\":[1,\"x\"]}", "values_um");
  bad("{" + r + "\"t0_us\":0,\"dt_us\":50,\"values_um\":[1,2],\"status\":[0]}", "status");
  bad("{" + r + "\"t0_us\":0,\"dt_us\":50,\"values_um\":[1,2],\"status\":0}", "status");
  bad("{" + r + "\"t0_us\":0,\"dt_us\":50,\"values_um\":[1,2],\"status\":[0,999]}", "status");
  bad("{" + r + "\"t0_us\":0,\"dt_us\":0,\"values_um\":[1,2]}", "dt_us");
  bad("{" + r + "\"t0_us\":0,\"dt_us\":-1,\"values_um\":[1,2]}", "dt_us");
  bad("{" + r + "\"t0_us\":0,\"dt_us\":1e300,\"values_um\":[1,2]}", "dt_us");
  bad("{" + r + "\"t0_us\":0,\"values_um\":[1,2]}", "dt_us");
  bad("{" + r + "\"dt_us\":5,\"values_um\":[1,2]}", "t0_us");
  bad("{" + r + "\"t0_us\":9223372036854775000,\"dt_us\":1000,\"values_um\":[1,2]}", "t0_us");
  bad("{" + r + "\"t0_us\":0,\"t_us\":[1,2],\"values_um\":[1,2]}", "t0_us");
  bad("{" + r + "\"t_us\":[1],\"values_um\":[1,2]}", "t_us");
  bad("{" + r + "\"t_us\":[1,\"2\"],\"values_um\":[1,2]}", "t_us");
  bad("{" + r + "\"t_us\":[1,2],\"values_um\":[1,2],\"counter\":1}", "counter");
  bad("{\"channel\":1,\"first_counter\":18446744073709551615,\"t_us\":[1,2],"
      "\"values_um\":[1,2]}",
      "first_counter");
  bad("{\"channel\":1,\"t_us\":[1,2],\"values_um\":[1,2]}", "first_counter");
  bad("{\"channel\":1,\"counter\":9223372036854775808,\"t_us\":30,\"value_um\":1}", "counter");
  bad("{\"channel\":1,\"counter\":3,\"t_us\":30,\"value_um\":1e999}", "value_um");
  bad("{\"channel\":1,\"counter\":3,\"t_us\":30,\"value_um\":[[1]]}", "value_um");
  bad("{" + r + "\"t0_us\":0,\"dt_us\":50,\"values_um\":[1,[2]]}", "values_um");
  // A run over the decoder's limit is TooLarge.
  bad("{" + r + "\"t_us\":[1,2,3],\"values_um\":[1,2,3]}", "values_um", 2);
  {
    StreamFrameDecoder dec(FrameFormat::kNdjson, "u", 2);
    EXPECT_THROW(
        dec.Feed("{" + r + "\"t_us\":[1,2,3],\"values_um\":[1,2,3]}\n", [](SampleRun&&) {}),
        TooLarge);
  }
}

TEST(StreamFrames, NdjsonLineLengthBounded) {
  // Limit 1 sample: lines may be at most 4096 + 80 bytes; a longer one is
  // refused while it is still arriving (no newline needed).
  StreamFrameDecoder dec(FrameFormat::kNdjson, "u", 1);
  const std::string chunk(1000, ' ');
  std::size_t fed = 0;
  try {
    for (int i = 0; i < 10; ++i) {
      dec.Feed(chunk, [](SampleRun&&) {});
      fed += chunk.size();
    }
    FAIL() << "no error";
  } catch (const TooLarge& e) {
    EXPECT_EQ(e.field(), "line");
    EXPECT_EQ(e.line(), 1u);
    EXPECT_LE(fed, 4096u + 80u);
  }
}

TEST(StreamFrames, NdjsonTruncation) {
  const std::string line = "{\"channel\":1,\"counter\":1,\"t_us\":10,\"value_um\":0.5}";
  // Finish() without a callback cannot deliver a pending line: an unterminated
  // one is an error.
  {
    const Failure f = DecodeExpectingError(FrameFormat::kNdjson, line + "\n" + line);
    EXPECT_EQ(f.error.line(), 2u);
    EXPECT_EQ(f.error.field(), "line");
    EXPECT_EQ(f.delivered.size(), 1u);
  }
  // Finish(on_run) accepts a complete unterminated last line …
  {
    StreamFrameDecoder dec(FrameFormat::kNdjson, "u");
    std::vector<SampleRun> runs;
    auto sink = [&](SampleRun&& r) { runs.push_back(std::move(r)); };
    dec.Feed(line + "\n" + line, sink);
    EXPECT_EQ(runs.size(), 1u);
    dec.Finish(sink);
    EXPECT_EQ(runs.size(), 2u);
    EXPECT_EQ(dec.frames(), 2u);
  }
  // … but not a truncated one, at any cut.
  for (std::size_t cut = 1; cut < line.size(); ++cut) {
    StreamFrameDecoder dec(FrameFormat::kNdjson, "u");
    dec.Feed(line + "\n" + line.substr(0, cut), [](SampleRun&&) {});
    try {
      dec.Finish([](SampleRun&&) {});
      FAIL() << "cut " << cut;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.line(), 2u);
      EXPECT_TRUE(e.field() == "json" || e.field() == "value_um") << cut << " " << e.what();
    }
  }
  // Trailing blank text is fine.
  EXPECT_EQ(DecodeAll(FrameFormat::kNdjson, line + "\n  \r").size(), 1u);
}

}  // namespace
}  // namespace km::ingest
