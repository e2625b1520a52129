// Shared helpers of the stream-frame tests: a hand-written frame builder (byte
// by byte from the format description, independent of the product's encoder)
// and random runs.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/crc32.h"
#include "ingest/stream/stream_frames.h"

namespace km::ingest::test {

inline void PutLe(std::string& s, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFFu));
}

struct RawFrame {
  std::string magic = "KMSF";
  std::uint8_t version = 1;
  std::uint8_t flags = 0;
  std::uint16_t channel = 0;
  std::uint32_t n = 0;
  std::uint64_t first_counter = 0;
  std::int64_t t0_us = 0;
  std::uint32_t dt_ns = 0;
  std::vector<double> values;
  std::vector<std::int64_t> times;
  std::vector<std::uint8_t> status;

  // Serialises the fields as given (no consistency checks), CRC from the
  // bitwise reference.
  std::string Bytes() const {
    std::string s = magic;
    PutLe(s, version, 1);
    PutLe(s, flags, 1);
    PutLe(s, channel, 2);
    PutLe(s, n, 4);
    PutLe(s, first_counter, 8);
    PutLe(s, static_cast<std::uint64_t>(t0_us), 8);
    PutLe(s, dt_ns, 4);
    for (double v : values) {
      std::uint64_t u;
      std::memcpy(&u, &v, 8);
      PutLe(s, u, 8);
    }
    for (std::int64_t t : times) PutLe(s, static_cast<std::uint64_t>(t), 8);
    for (std::uint8_t b : status) PutLe(s, b, 1);
    PutLe(s, Crc32Bitwise(s), 4);
    return s;
  }
};

// t_k = t0 + (k·dt_ns + 500)/1000 computed in 128-bit to be independent of the
// product.
inline std::int64_t UniformT(std::int64_t t0, std::uint64_t k, std::uint32_t dt_ns) {
  const __int128 off = (static_cast<__int128>(k) * dt_ns + 500) / 1000;
  return static_cast<std::int64_t>(t0 + off);
}

inline SampleRun RandomRun(std::mt19937& rng, std::size_t n, std::uint32_t dt_ns, bool random_times,
                           bool random_status) {
  SampleRun r;
  r.channel = std::uniform_int_distribution<std::uint32_t>(0, 65535)(rng);
  r.first_counter = std::uniform_int_distribution<std::uint64_t>(0, std::uint64_t{1} << 62)(rng);
  const std::int64_t t0 =
      1763700000000000 + std::uniform_int_distribution<std::int64_t>(0, 1000000000)(rng);
  std::normal_distribution<double> value(0.0, 50.0);
  std::uniform_int_distribution<std::int64_t> jitter(0, 1000);
  std::uniform_int_distribution<int> st(0, 255);
  std::int64_t t = t0;
  for (std::size_t k = 0; k < n; ++k) {
    r.value_um.push_back(value(rng));
    if (random_times) {
      r.t_us.push_back(t);
      t += jitter(rng);
    } else {
      r.t_us.push_back(UniformT(t0, k, dt_ns));
    }
    r.status.push_back(random_status ? static_cast<std::uint8_t>(st(rng)) : 0);
  }
  return r;
}

// Bit-exact equality of two runs (doubles compared by representation).
inline bool SameRun(const SampleRun& a, const SampleRun& b) {
  if (a.channel != b.channel || a.first_counter != b.first_counter || a.t_us != b.t_us ||
      a.status != b.status || a.value_um.size() != b.value_um.size()) {
    return false;
  }
  return std::memcmp(a.value_um.data(), b.value_um.data(), a.value_um.size() * sizeof(double)) == 0;
}

// Decodes `bytes` fed in pieces cut at `cuts`; checks the decoder's frame and byte counts.
inline std::vector<SampleRun> DecodeAll(FrameFormat format, const std::string& bytes,
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
inline Failure DecodeExpectingError(FrameFormat format, const std::string& bytes,
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

}  // namespace km::ingest::test
