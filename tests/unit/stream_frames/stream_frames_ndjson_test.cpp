// NDJSON stream frames (ingest/stream/stream_frames.h, docs/formats.md): shapes, round trips, split
// feeding, counters, every error with its line and field, line length and truncation.
#include "ingest/stream/stream_frames.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
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
using test::SameRun;

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
