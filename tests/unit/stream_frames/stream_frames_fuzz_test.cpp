// Fuzz-style robustness (seeded, deterministic): random bytes, mutated valid
// streams (with and without recomputed CRCs) and truncations, fed in random
// pieces. Each input must either decode or end in a clean km::InvalidInput;
// anything else (another exception, a crash, an out-of-bounds read under
// AddressSanitizer) fails. Delivered runs must be self-consistent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/crc32.h"
#include "ingest/stream/stream_frames.h"
#include "tests/unit/stream_frames/stream_frames_test_util.h"

namespace km::ingest {
namespace {

struct Outcome {
  bool ok = false;
  std::size_t runs = 0;
};

Outcome FeedRandomly(FrameFormat format, const std::string& bytes, std::mt19937& rng,
                     std::size_t limit) {
  StreamFrameDecoder dec(format, "fuzz", limit);
  Outcome out;
  auto check = [&](SampleRun&& r) {
    ++out.runs;
    ASSERT_GE(r.size(), 1u);
    ASSERT_LE(r.size(), limit);
    ASSERT_EQ(r.t_us.size(), r.size());
    ASSERT_EQ(r.status.size(), r.size());
    ASSERT_LE(r.channel, 65535u);
    for (double v : r.value_um) ASSERT_TRUE(std::isfinite(v));
  };
  std::uniform_int_distribution<std::size_t> piece(0, 80);
  try {
    std::size_t at = 0;
    while (at < bytes.size()) {
      const std::size_t len = std::min(piece(rng), bytes.size() - at);
      dec.Feed(std::string_view(bytes).substr(at, len), check);
      at += len;
    }
    dec.Finish(check);
    out.ok = true;
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "fuzz");
    EXPECT_FALSE(e.field().empty()) << e.what();
  }
  EXPECT_EQ(dec.frames(), out.runs);
  return out;
}

std::string ValidBinaryStream(std::mt19937& rng, std::vector<std::size_t>* frame_ends) {
  std::string s;
  std::uniform_int_distribution<int> coin(0, 3);
  std::uniform_int_distribution<std::size_t> len(1, 40);
  for (int i = 0; i < 6; ++i) {
    const int flags = coin(rng);
    const bool st = flags & 1, ts = flags & 2;
    const SampleRun run = test::RandomRun(rng, len(rng), 20000, ts, st);
    s += EncodeBinaryFrame(run, ts, st, 20000);
    frame_ends->push_back(s.size());
  }
  return s;
}

std::string ValidNdjsonStream(std::mt19937& rng) {
  std::string s;
  std::uniform_int_distribution<std::size_t> len(1, 12);
  for (int i = 0; i < 6; ++i) {
    s += EncodeNdjsonRun(test::RandomRun(rng, len(rng), 0, true, i % 2 == 0));
    if (i % 3 == 0)
      s += "{\"channel\":2,\"first_counter\":1,\"t0_us\":5,\"dt_us\":33.3,"
           "\"values_um\":[1,2]}\r\n";
    s += EncodeNdjsonSample({1, 2, 3, 4.5, 6});
  }
  return s;
}

void Mutate(std::string& s, std::mt19937& rng, const std::string& alphabet) {
  if (s.empty()) return;
  std::uniform_int_distribution<int> count(1, 4);
  std::uniform_int_distribution<int> kind(0, 3);
  std::uniform_int_distribution<int> byte(0, 255);
  const int m = count(rng);
  for (int i = 0; i < m && !s.empty(); ++i) {
    std::uniform_int_distribution<std::size_t> pos(0, s.size() - 1);
    const std::size_t p = pos(rng);
    switch (kind(rng)) {
      case 0:
        s[p] = static_cast<char>(s[p] ^ (1 << (byte(rng) % 8)));
        break;
      case 1:
        s[p] = alphabet.empty() ? static_cast<char>(byte(rng))
                                : alphabet[static_cast<std::size_t>(byte(rng)) % alphabet.size()];
        break;
      case 2:
        s.erase(p, 1 + static_cast<std::size_t>(byte(rng)) % 8);
        break;
      default:
        s.insert(p, 1, static_cast<char>(byte(rng)));
        break;
    }
  }
}

// Rewrites each frame's CRC at its original place so that mutations reach the
// checks behind it.
void RecomputeCrcs(std::string& s, const std::vector<std::size_t>& frame_ends) {
  std::size_t begin = 0;
  for (std::size_t end : frame_ends) {
    if (end > s.size() || end < begin + 4) break;
    const std::uint32_t crc = Crc32Update(0, s.data() + begin, end - 4 - begin);
    for (int i = 0; i < 4; ++i) s[end - 4 + i] = static_cast<char>((crc >> (8 * i)) & 0xFF);
    begin = end;
  }
}

TEST(StreamFramesFuzz, RandomBytes) {
  for (unsigned seed : {101u, 102u, 103u}) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::size_t> len(0, 300);
    std::uniform_int_distribution<int> byte(0, 255);
    for (int trial = 0; trial < 1000; ++trial) {
      std::string s(len(rng), '\0');
      for (char& c : s) c = static_cast<char>(byte(rng));
      if (trial % 3 == 0 && s.size() >= 4) s.replace(0, 4, "KMSF");  // get past the magic
      if (trial % 3 == 1 && s.size() >= 6) s.replace(0, 6, "KMSF\x01\x00", 6);
      FeedRandomly(FrameFormat::kBinary, s, rng, 64);
      FeedRandomly(FrameFormat::kNdjson, s, rng, 64);
    }
  }
}

TEST(StreamFramesFuzz, MutatedBinaryStreams) {
  std::size_t decoded = 0, refused = 0;
  for (unsigned seed : {111u, 112u, 113u, 114u}) {
    std::mt19937 rng(seed);
    for (int trial = 0; trial < 600; ++trial) {
      std::vector<std::size_t> ends;
      std::string s = ValidBinaryStream(rng, &ends);
      ASSERT_TRUE(FeedRandomly(FrameFormat::kBinary, s, rng, 40).ok);
      Mutate(s, rng, "");
      if (trial % 2 == 0) RecomputeCrcs(s, ends);
      const Outcome o = FeedRandomly(FrameFormat::kBinary, s, rng, 40);
      (o.ok ? decoded : refused) += 1;
      // Truncation anywhere before the end is refused (by a check or by
      // Finish).
      std::vector<std::size_t> ends2;
      const std::string v = ValidBinaryStream(rng, &ends2);
      const std::size_t c = std::uniform_int_distribution<std::size_t>(0, v.size() - 1)(rng);
      const bool at_boundary = c == 0 || std::find(ends2.begin(), ends2.end(), c) != ends2.end();
      EXPECT_EQ(FeedRandomly(FrameFormat::kBinary, v.substr(0, c), rng, 40).ok, at_boundary);
    }
  }
  EXPECT_GT(refused, 0u);
}

TEST(StreamFramesFuzz, MutatedNdjsonStreams) {
  for (unsigned seed : {121u, 122u, 123u}) {
    std::mt19937 rng(seed);
    for (int trial = 0; trial < 500; ++trial) {
      std::string s = ValidNdjsonStream(rng);
      ASSERT_TRUE(FeedRandomly(FrameFormat::kNdjson, s, rng, 40).ok);
      Mutate(s, rng, "{}[]\",:0123456789.-e \n\r\\ux");
      FeedRandomly(FrameFormat::kNdjson, s, rng, 40);
      std::uniform_int_distribution<std::size_t> cut(0, s.size());
      FeedRandomly(FrameFormat::kNdjson, s.substr(0, cut(rng)), rng, 40);
    }
  }
}

}  // namespace
}  // namespace km::ingest
