// Register decoding (every type × byte order × word order against words built by hand from
// the value's bytes), scale/offset, and block planning.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "ingest/modbus/modbus_decode.h"
#include "tests/integration/modbus/modbus_pattern.h"

namespace km::ingest::modbus {
namespace {

namespace mp = km::test::modbus_pattern;

std::uint16_t W(std::uint8_t first_wire_byte, std::uint8_t second_wire_byte) {
  return static_cast<std::uint16_t>((first_wire_byte << 8) | second_wire_byte);
}

double Decode(const std::vector<std::uint16_t>& w, RegisterType t, ByteOrder b, WordOrder o) {
  return DecodeRaw(std::span<const std::uint16_t>(w.data(), w.size()), t, b, o);
}

// Literal wire bytes, written out per layout (no helper involved).
TEST(ModbusDecode, Float32InAllFourLayouts) {
  // -12.375 = 0xC1460000; 1234.5678f = 0x449A522B (all bytes distinct).
  const double f = static_cast<double>(1234.5678f);
  EXPECT_EQ(Decode({W(0xC1, 0x46), W(0x00, 0x00)}, RegisterType::kFloat32, ByteOrder::kBig,
                   WordOrder::kBig),
            -12.375);
  EXPECT_EQ(Decode({W(0x44, 0x9A), W(0x52, 0x2B)}, RegisterType::kFloat32, ByteOrder::kBig,
                   WordOrder::kBig),
            f);  // ABCD
  EXPECT_EQ(Decode({W(0x52, 0x2B), W(0x44, 0x9A)}, RegisterType::kFloat32, ByteOrder::kBig,
                   WordOrder::kLittle),
            f);  // CDAB
  EXPECT_EQ(Decode({W(0x9A, 0x44), W(0x2B, 0x52)}, RegisterType::kFloat32, ByteOrder::kLittle,
                   WordOrder::kBig),
            f);  // BADC
  EXPECT_EQ(Decode({W(0x2B, 0x52), W(0x9A, 0x44)}, RegisterType::kFloat32, ByteOrder::kLittle,
                   WordOrder::kLittle),
            f);  // DCBA
}

TEST(ModbusDecode, IntegersLiteralBytes) {
  // -123456789 = 0xF8A432EB, 4000000000 = 0xEE6B2800, -2 = 0xFFFE, 65534 = 0xFFFE.
  EXPECT_EQ(Decode({W(0xF8, 0xA4), W(0x32, 0xEB)}, RegisterType::kInt32, ByteOrder::kBig,
                   WordOrder::kBig),
            -123456789.0);
  EXPECT_EQ(Decode({W(0xEB, 0x32), W(0xA4, 0xF8)}, RegisterType::kInt32, ByteOrder::kLittle,
                   WordOrder::kLittle),
            -123456789.0);
  EXPECT_EQ(Decode({W(0x28, 0x00), W(0xEE, 0x6B)}, RegisterType::kUint32, ByteOrder::kBig,
                   WordOrder::kLittle),
            4000000000.0);
  EXPECT_EQ(Decode({W(0x6B, 0xEE), W(0x00, 0x28)}, RegisterType::kUint32, ByteOrder::kLittle,
                   WordOrder::kBig),
            4000000000.0);
  EXPECT_EQ(Decode({W(0xFF, 0xFE)}, RegisterType::kInt16, ByteOrder::kBig, WordOrder::kBig), -2.0);
  EXPECT_EQ(Decode({W(0xFE, 0xFF)}, RegisterType::kInt16, ByteOrder::kLittle, WordOrder::kBig),
            -2.0);
  EXPECT_EQ(Decode({W(0xFF, 0xFE)}, RegisterType::kUint16, ByteOrder::kBig, WordOrder::kBig),
            65534.0);
  EXPECT_EQ(Decode({W(0xFE, 0xFF)}, RegisterType::kUint16, ByteOrder::kLittle, WordOrder::kLittle),
            65534.0);
  EXPECT_EQ(Decode({W(0x80, 0x00)}, RegisterType::kInt16, ByteOrder::kBig, WordOrder::kBig),
            -32768.0);
  EXPECT_EQ(Decode({W(0x80, 0x00), W(0x00, 0x00)}, RegisterType::kInt32, ByteOrder::kBig,
                   WordOrder::kBig),
            -2147483648.0);
}

// Every type × byte order × word order for the pattern values and random values: the words
// come from modbus_pattern.h's byte-permutation tables, not from the decoder.
TEST(ModbusDecode, EveryTypeAndOrderRoundTripsHandBuiltWords) {
  const std::vector<std::pair<std::string, RegisterType>> types = {
      {"int16", RegisterType::kInt16},
      {"uint16", RegisterType::kUint16},
      {"int32", RegisterType::kInt32},
      {"uint32", RegisterType::kUint32},
      {"float32", RegisterType::kFloat32}};
  for (unsigned seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    for (const auto& [name, type] : types) {
      std::vector<double> values;
      if (name == "int16") values = {-2.0, -32768.0, 32767.0, 0.0};
      if (name == "uint16") values = {65534.0, 65535.0, 0.0, 258.0};
      if (name == "int32") values = {-123456789.0, -2147483648.0, 2147483647.0};
      if (name == "uint32") values = {4000000000.0, 4294967295.0, 16909060.0};
      if (name == "float32") values = {-12.375, static_cast<double>(1234.5678f), 1e-30f};
      for (int i = 0; i < 50; ++i) {
        const std::uint32_t bits = rng();
        if (name == "int16") values.push_back(static_cast<std::int16_t>(bits));
        if (name == "uint16") values.push_back(static_cast<std::uint16_t>(bits));
        if (name == "int32") values.push_back(static_cast<std::int32_t>(bits));
        if (name == "uint32") values.push_back(bits);
        if (name == "float32") {
          const float f = std::bit_cast<float>(bits);
          if (std::isfinite(f)) values.push_back(f);
        }
      }
      for (double v : values) {
        for (const char* bo : {"big", "little"}) {
          for (const char* wo : {"big", "little"}) {
            const mp::Entry e{0, name, bo, wo, v, 1.0, 0.0};
            const auto words = mp::WireWords(e);
            ByteOrder b;
            WordOrder o;
            ASSERT_TRUE(ParseByteOrder(bo, &b));
            ASSERT_TRUE(ParseWordOrder(wo, &o));
            ASSERT_EQ(Decode(words, type, b, o), v)
                << name << " " << mp::Layout(bo, wo, RegisterCount(type)) << " seed " << seed;
          }
        }
      }
    }
  }
}

TEST(ModbusDecode, LayoutsDifferSoOrderMatters) {
  // Decoding ABCD words as any other layout must give a different value for distinct bytes.
  const mp::Entry e{0, "uint32", "big", "big", 16909060.0, 1.0, 0.0};  // 0x01020304
  const auto w = mp::WireWords(e);
  EXPECT_EQ(Decode(w, RegisterType::kUint32, ByteOrder::kBig, WordOrder::kLittle), 0x03040102);
  EXPECT_EQ(Decode(w, RegisterType::kUint32, ByteOrder::kLittle, WordOrder::kBig), 0x02010403);
  EXPECT_EQ(Decode(w, RegisterType::kUint32, ByteOrder::kLittle, WordOrder::kLittle), 0x04030201);
}

TEST(ModbusDecode, WrongRegisterCountThrowsAndNamesRoundTrip) {
  EXPECT_THROW(Decode({1}, RegisterType::kFloat32, ByteOrder::kBig, WordOrder::kBig),
               std::invalid_argument);
  EXPECT_THROW(Decode({1, 2}, RegisterType::kInt16, ByteOrder::kBig, WordOrder::kBig),
               std::invalid_argument);
  for (RegisterType t : {RegisterType::kInt16, RegisterType::kUint16, RegisterType::kInt32,
                         RegisterType::kUint32, RegisterType::kFloat32}) {
    RegisterType back;
    ASSERT_TRUE(ParseRegisterType(ToString(t), &back));
    EXPECT_EQ(back, t);
  }
  RegisterType t;
  EXPECT_FALSE(ParseRegisterType("float64", &t));
  ByteOrder b;
  EXPECT_FALSE(ParseByteOrder("BIG", &b));
}

TEST(ModbusDecode, ScaleAndOffset) {
  EXPECT_EQ(ApplyScale(-2.0, 0.5, 10.0), 9.0);
  EXPECT_EQ(ApplyScale(-12.375, 2.0, -1.0), -25.75);
  // A 16-bit ADC count to µm: 0..65535 → -500..+500 µm.
  const double scale = 1000.0 / 65535.0;
  EXPECT_NEAR(ApplyScale(0.0, scale, -500.0), -500.0, 1e-12);
  EXPECT_NEAR(ApplyScale(65535.0, scale, -500.0), 500.0, 1e-9);
}

// Brute-force reference for PlanBlocks: the same greedy rule written as a scan over
// sorted spans, plus the invariants every plan must satisfy.
void CheckPlan(const std::vector<RegisterSpan>& spans, const std::vector<ReadBlock>& blocks,
               int max_registers) {
  std::vector<int> seen(spans.size(), 0);
  std::uint32_t previous_end = 0;
  for (std::size_t bi = 0; bi < blocks.size(); ++bi) {
    const ReadBlock& b = blocks[bi];
    ASSERT_GE(b.count, 1);
    ASSERT_LE(b.count, max_registers);
    ASSERT_EQ(b.members.size(), b.offsets.size());
    if (bi > 0) {
      ASSERT_GE(b.start, previous_end);
    }
    previous_end = b.start + static_cast<std::uint32_t>(b.count);
    std::uint32_t end = b.start;
    for (std::size_t m = 0; m < b.members.size(); ++m) {
      const RegisterSpan& s = spans[b.members[m]];
      ++seen[b.members[m]];
      ASSERT_EQ(static_cast<std::uint32_t>(b.offsets[m]), s.address - b.start);
      end = std::max(end, s.address + static_cast<std::uint32_t>(s.count));
    }
    ASSERT_EQ(b.start, spans[b.members.front()].address);
    ASSERT_EQ(end, previous_end);  // the block ends at its last value
    // Greedy: the next block's first value would not have fitted in this one.
    if (bi + 1 < blocks.size()) {
      const RegisterSpan& next = spans[blocks[bi + 1].members.front()];
      ASSERT_GT(next.address + static_cast<std::uint32_t>(next.count) - b.start,
                static_cast<std::uint32_t>(max_registers));
    }
  }
  for (int s : seen) ASSERT_EQ(s, 1);
}

TEST(ModbusBlocks, OneBlockWhenTheSpanFits) {
  const std::vector<RegisterSpan> spans = {{10, 2}, {0, 1}, {122, 2}, {5, 1}};
  const auto blocks = PlanBlocks(spans);
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].start, 0u);
  EXPECT_EQ(blocks[0].count, 124);
  EXPECT_EQ(blocks[0].members, (std::vector<std::size_t>{1, 3, 0, 2}));
  EXPECT_EQ(blocks[0].offsets, (std::vector<int>{0, 5, 10, 122}));
  CheckPlan(spans, blocks, 125);
}

TEST(ModbusBlocks, SplitsAt125RegistersAndAtTheTop) {
  // 0..124 is exactly 125 registers; a float at 124 ends at 126 → second block.
  auto blocks = PlanBlocks({{0, 1}, {123, 2}});
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].count, 125);
  blocks = PlanBlocks({{0, 1}, {124, 2}});
  ASSERT_EQ(blocks.size(), 2u);
  EXPECT_EQ(blocks[1].start, 124u);
  EXPECT_EQ(blocks[1].count, 2);
  blocks = PlanBlocks({{65534, 2}, {0, 1}});
  ASSERT_EQ(blocks.size(), 2u);
  EXPECT_EQ(blocks[1].start, 65534u);
  EXPECT_THROW(PlanBlocks({{65535, 2}}), std::invalid_argument);
  EXPECT_THROW(PlanBlocks({{4, 2}, {5, 1}}), std::invalid_argument);  // overlap
  EXPECT_TRUE(PlanBlocks({}).empty());
}

TEST(ModbusBlocks, RandomMapsSatisfyTheInvariants) {
  for (unsigned seed : {11u, 12u, 13u, 14u}) {
    std::mt19937 rng(seed);
    for (int trial = 0; trial < 200; ++trial) {
      std::vector<RegisterSpan> spans;
      std::uint32_t a = rng() % 50;
      const int n = 1 + static_cast<int>(rng() % 40);
      for (int i = 0; i < n && a < 65000; ++i) {
        const int count = 1 + static_cast<int>(rng() % 2);
        spans.push_back({a, count});
        a += static_cast<std::uint32_t>(count) + rng() % 60;
      }
      std::shuffle(spans.begin(), spans.end(), rng);
      const int max_registers = 2 + static_cast<int>(rng() % 124);
      const auto blocks = PlanBlocks(spans, max_registers);
      CheckPlan(spans, blocks, max_registers);
    }
  }
}

}  // namespace
}  // namespace km::ingest::modbus
