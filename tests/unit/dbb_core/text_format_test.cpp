#include "ingest/text_format.h"

#include <gtest/gtest.h>

#include "analysis/core/errors.h"

namespace km::ingest {
namespace {

TEST(TextFormat, StrictNumbers) {
  EXPECT_EQ(ParseNumber("1.5"), 1.5);
  EXPECT_EQ(ParseNumber(" -2e-3 "), -2e-3);
  EXPECT_EQ(ParseNumber("+4"), 4.0);
  for (const char* bad : {"", "nan", "NaN", "inf", "-inf", "1.5x", "0x10", "1,5", "1e400", "--1"}) {
    EXPECT_FALSE(ParseNumber(bad).has_value()) << bad;
  }
  EXPECT_EQ(ParseNumberList("1, 2,3")->size(), 3u);
  EXPECT_FALSE(ParseNumberList("1,,3").has_value());
}

TEST(TextFormat, MarkersRepeatableKeysAndMetadata) {
  ReadOptions o;
  o.repeatable_keys = {"guess"};
  const auto t = ReadTextTable(
      "# format: x/1\n# guess: 1\n# guess: 2\n\na,b\n1,2\n# beam_break: 2, 5\n3,4\n", "f", o);
  EXPECT_EQ(t.format, "x/1");
  EXPECT_EQ(t.FindAll("guess").size(), 2u);
  ASSERT_EQ(t.markers.size(), 1u);
  EXPECT_EQ(t.markers[0].key, "beam_break");
  EXPECT_EQ(t.markers[0].before_row, 1u);
  EXPECT_EQ(t.markers[0].line, 7u);
  EXPECT_EQ(t.row_lines[1], 8u);
  EXPECT_EQ(t.Metadata().at("guess"), "1; 2");
}

TEST(TextFormat, PeekFormat) {
  EXPECT_EQ(PeekFormat("\n\n# format: kinemetric-dbb/1\n", "f"), "kinemetric-dbb/1");
  EXPECT_THROW(PeekFormat("# machine_id: x\n", "f"), InvalidInput);
  EXPECT_THROW(PeekFormat("", "f"), InvalidInput);
}

}  // namespace
}  // namespace km::ingest
