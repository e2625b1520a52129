#include "ingest/stream/stream_frames.h"

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

using test::DecodeAll;
using test::DecodeExpectingError;
using test::Failure;
using test::RandomRun;

using test::RawFrame;
using test::SameRun;

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

}  // namespace
}  // namespace km::ingest
