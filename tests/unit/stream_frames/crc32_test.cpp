#include "ingest/crc32.h"

#include <gtest/gtest.h>

#include <random>
#include <string>

#include <zlib.h>

namespace km::ingest {
namespace {

std::string RandomBytes(std::mt19937& rng, std::size_t n) {
  std::uniform_int_distribution<int> byte(0, 255);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(byte(rng));
  return s;
}

TEST(Crc32, KnownCheckValues) {
  EXPECT_EQ(Crc32("123456789"),
            0xCBF43926u);  // the catalogued check value of CRC-32/ISO-HDLC
  EXPECT_EQ(Crc32(""), 0x00000000u);
  EXPECT_EQ(Crc32("a"), 0xE8B7BE43u);
  EXPECT_EQ(Crc32("The quick brown fox jumps over the lazy dog"), 0x414FA339u);
  EXPECT_EQ(Crc32(std::string(32, '\0')), 0x190A55ADu);
  EXPECT_EQ(Crc32Bitwise("123456789"), 0xCBF43926u);
}

TEST(Crc32, SlicingMatchesBitwiseReferenceForEveryLengthAndAlignment) {
  for (unsigned seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    const std::string data = RandomBytes(rng, 300);
    for (std::size_t off = 0; off < 8; ++off) {
      for (std::size_t len = 0; off + len <= data.size(); len += 1 + len / 16) {
        const std::string_view part(data.data() + off, len);
        ASSERT_EQ(Crc32(part), Crc32Bitwise(part))
            << "seed " << seed << " off " << off << " len " << len;
      }
    }
  }
}

TEST(Crc32, RunningUpdateEqualsOneShot) {
  for (unsigned seed : {4u, 5u, 6u}) {
    std::mt19937 rng(seed);
    const std::string data = RandomBytes(rng, 1000);
    std::uniform_int_distribution<std::size_t> cut(0, data.size());
    for (int trial = 0; trial < 50; ++trial) {
      std::size_t a = cut(rng), b = cut(rng);
      if (a > b) std::swap(a, b);
      std::uint32_t c = Crc32Update(0, data.data(), a);
      c = Crc32Update(c, data.data() + a, b - a);
      c = Crc32Update(c, data.data() + b, data.size() - b);
      ASSERT_EQ(c, Crc32(data));
    }
  }
}

// zlib's crc32() is an independent implementation of the same CRC (zlib1g-dev, installed by
// deploy/install-deps.sh).
TEST(Crc32, MatchesZlib) {
  for (unsigned seed : {7u, 8u, 9u}) {
    std::mt19937 rng(seed);
    for (std::size_t len : {0u, 1u, 7u, 8u, 9u, 63u, 64u, 65u, 1000u, 4099u}) {
      const std::string data = RandomBytes(rng, len);
      const auto z = crc32(0L, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(len));
      ASSERT_EQ(Crc32(data), static_cast<std::uint32_t>(z)) << "len " << len;
    }
  }
}

}  // namespace
}  // namespace km::ingest
