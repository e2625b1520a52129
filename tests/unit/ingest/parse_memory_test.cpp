// Peak memory of parsing large files, counted by this test binary's own global operator new:
// the parse of a 20 MB file must not allocate more than about 3 times the file size at peak
// (it used to take some 22 times: a vector and a string per row and per cell).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "analysis/core/errors.h"
#include "ingest/dbb_parser.h"
#include "ingest/form_parsers.h"
#include "ingest/tracker_parser.h"
#include "tests/unit/ingest/big_files.h"
#include "tests/unit/ingest/counting_new.h"

namespace km::ingest {
namespace {

constexpr double kMaxPeakPerByte = 3.0;

// Peak bytes per input byte, printed and checked.
void Check(std::size_t peak, const std::string& text) {
  const double per_byte = static_cast<double>(peak) / static_cast<double>(text.size());
  std::printf("  %.1f MB parsed, %.1f MB allocated at peak: %.2f bytes per input byte\n",
              static_cast<double>(text.size()) / 1e6, static_cast<double>(peak) / 1e6, per_byte);
  EXPECT_LE(per_byte, kMaxPeakPerByte) << peak << " bytes at peak for " << text.size();
}

TEST(ParseMemory, CountingWorks) {
  const std::size_t peak = test::PeakOf([] {
    std::string s(1 << 20, 'x');
    ASSERT_EQ(s.size(), 1u << 20);
  });
  EXPECT_GE(peak, 1u << 20);
  EXPECT_LT(peak, 2u << 20);
}

TEST(ParseMemory, DbbFileOf20MB) {
  const std::string text = test::BigDbbFile(1'000'000);
  ASSERT_GT(text.size(), 19u << 20);
  std::size_t samples = 0;
  const std::size_t peak = test::PeakOf([&] { samples = ParseDbb(text, "big.txt").dr_um.size(); });
  EXPECT_EQ(samples, 1'000'000u);
  Check(peak, text);
}

TEST(ParseMemory, StraightnessFileOf20MB) {
  const std::string text = test::BigStraightnessFile(1'000'000);  // the parser's ceiling
  ASSERT_GT(text.size(), 19u << 20);
  std::size_t points = 0;
  const std::size_t peak = test::PeakOf(
      [&] { points = ParseStraightnessFile(text, "big.txt").profile.position_mm.size(); });
  EXPECT_EQ(points, 1'000'000u);
  Check(peak, text);
}

TEST(ParseMemory, FlatnessFileOf25MB) {
  const std::string text = test::BigFlatnessFile(1000);
  std::size_t points = 0;
  const std::size_t peak =
      test::PeakOf([&] { points = ParseFlatnessFile(text, "big.txt").grid.z_um.size(); });
  EXPECT_EQ(points, 1'000'000u);
  Check(peak, text);
}

TEST(ParseMemory, TrackerFileOf8MB) {
  const std::string text = test::BigTrackerFile(50);  // 125 000 points
  ASSERT_GT(text.size(), 8u << 20);
  std::size_t points = 0;
  const std::size_t peak =
      test::PeakOf([&] { points = ParseTrackerFile(text, "big.txt").readings.point_ids.size(); });
  EXPECT_EQ(points, 50u * 50u * 50u);
  Check(peak, text);
}

// 20 MB of very short rows (4 to 8 bytes a row) used to take over 20 times their size before
// the row limit was met; now the limit is found by a scan that allocates nothing.
TEST(ParseMemory, ShortRowsBeyondTheRowLimitAreRefusedWithoutAllocating) {
  std::string dbb = test::BigDbbFile(16);
  const std::string head = dbb.substr(0, dbb.find("angle_deg,dr_um\n") + 16);
  std::string straight = test::BigStraightnessFile(3);
  straight = straight.substr(0, straight.find("position_mm,deviation_um\n") + 25);
  dbb = head;
  dbb.reserve(20u << 20);
  straight.reserve(20u << 20);
  for (int i = 0; dbb.size() < (20u << 20); ++i) dbb += std::to_string(i % 1000) + ",1\n";
  for (int i = 0; straight.size() < (20u << 20); ++i) straight += "1,2\n";
  std::size_t line = 0;
  const std::size_t peak_dbb = test::PeakOf([&] {
    try {
      ParseDbb(dbb, "short.txt");
    } catch (const TooLarge& e) {
      line = e.line();
    }
  });
  EXPECT_EQ(line, 8u + 2'000'001u);
  EXPECT_LT(peak_dbb, 1u << 20);
  line = 0;
  const std::size_t peak_straight = test::PeakOf([&] {
    try {
      ParseStraightnessFile(straight, "short.txt");
    } catch (const TooLarge& e) {
      line = e.line();
    }
  });
  EXPECT_EQ(line, 7u + 1'000'001u);
  EXPECT_LT(peak_straight, 1u << 20);
}

}  // namespace
}  // namespace km::ingest
