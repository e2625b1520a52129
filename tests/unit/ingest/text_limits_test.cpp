// The generic text reader (ingest/text_format.h): strict UTF-8, error messages that never echo
// raw bytes, the format line checked before use, limits refused at the first line beyond them,
// and the compact column storage.
#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"
#include "ingest/dbb_parser.h"
#include "ingest/form_parsers.h"
#include "ingest/text_format.h"
#include "ingest/tracker_parser.h"
#include "tests/unit/expect_error.h"

namespace km::ingest {
namespace {

bool Utf8(const std::string& s) {
  std::size_t at = 0;
  return ValidUtf8(s, at);
}

using km::test::Contains;
using km::test::Expect;

const std::string kHead = "# format: x/1\n# note: ";  // the value is on line 2

TEST(Utf8, OverlongSurrogatesAndBeyondU10FFFFAreRefusedNamingLineAndColumn) {
  struct Case {
    std::string bytes, shown, why;
  };
  const Case cases[] = {
      {"\xE0\x80\x80", "\\xE0\\x80\\x80", "overlong"},  // U+0000 in three bytes
      {"\xE0\x9F\xBF", "\\xE0\\x9F\\xBF", "overlong"},  // U+07FF in three bytes
      {"\xF0\x80\x80\x80", "\\xF0\\x80\\x80\\x80", "overlong"},
      {"\xF0\x8F\xBF\xBF", "\\xF0\\x8F\\xBF\\xBF", "overlong"},  // U+FFFF in four bytes
      {"\xC0\xAF", "\\xC0\\xAF", "overlong"},
      {"\xC1\xBF", "\\xC1\\xBF", "overlong"},
      {"\xED\xA0\x80", "\\xED\\xA0\\x80", "surrogate"},  // U+D800
      {"\xED\xBF\xBF", "\\xED\\xBF\\xBF", "surrogate"},  // U+DFFF
      {"\xF4\x90\x80\x80", "\\xF4\\x90\\x80\\x80", "above U+10FFFF"},
      {"\xF5\x80\x80\x80", "\\xF5", "never occurs"},
      {"\xFF", "\\xFF", "never occurs"},
      {"\x80", "\\x80", "continuation"},
      {"\xE2\x82", "\\xE2\\x82", "cut short"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.shown);
    std::size_t at = 99;
    std::string why;
    EXPECT_FALSE(ValidUtf8("ab" + c.bytes + "\n", at, &why));
    EXPECT_EQ(at, 2u);
    EXPECT_TRUE(Contains(why, c.why)) << why;
    const std::string text = kHead + "abc" + c.bytes + "\nq,r\n1,2\n";
    const auto e = Expect<InvalidInput>([&] { ReadTextTable(text, "u.txt"); });
    EXPECT_EQ(e.file(), "u.txt");
    EXPECT_EQ(e.line(), 2u) << e.what();
    EXPECT_TRUE(Contains(e.what(), "byte column 12")) << e.what();
    EXPECT_TRUE(Contains(e.what(), c.shown)) << e.what();
    EXPECT_TRUE(Utf8(e.what())) << e.what();
  }
}

TEST(Utf8, EveryValidCodePointRangeIsAccepted) {
  for (const char* ok :
       {"\xC2\x80", "\xDF\xBF", "\xE0\xA0\x80", "\xED\x9F\xBF", "\xEE\x80\x80", "\xEF\xBF\xBF",
        "\xF0\x90\x80\x80", "\xF4\x8F\xBF\xBF", "\xC2\xB5m", "\xE2\x82\xAC"}) {
    std::size_t at = 0;
    EXPECT_TRUE(ValidUtf8("x" + std::string(ok) + "y", at)) << at;
    char32_t cp = 0;
    ASSERT_GT(Utf8Decode(ok, 0, cp), 0u);
    if (IsInvisibleOrControl(cp)) {  // U+0080: valid UTF-8, but a control in a header value
      const auto e =
          Expect<InvalidInput>([&] { ReadTextTable(kHead + ok + "\nq,r\n1,2\n", "u.txt"); });
      EXPECT_EQ(e.field(), "note");
      continue;
    }
    const auto t = ReadTextTable(kHead + ok + "\nq,r\n1,2\n", "u.txt");
    EXPECT_EQ(t.Find("note")->value, ok);
  }
}

TEST(Quote, EscapesControlsAndInvalidBytesAndCutsAtCharacters) {
  EXPECT_EQ(Quote("abc"), "'abc'");
  EXPECT_EQ(Quote("a\x1b[0m\tb\\"), "'a\\x1B[0m\\x09b\\\\'");
  EXPECT_EQ(Quote("\xff\xed\xa0\x80z"), "'\\xFF\\xED\\xA0\\x80z'");
  EXPECT_EQ(Quote("\xE2\x82\xAC\xE2\x82\xAC\xE2\x82\xAC", 2), "'\xE2\x82\xAC\xE2\x82\xAC...'");
  EXPECT_EQ(Quote("12345", 5), "'12345'");
  EXPECT_EQ(Quote("a\xC2\x85"
                  "b\xE2\x80\xAE"),
            "'a\\u{85}b\\u{202E}'");
}

TEST(Messages, QuotedContentIsEscapedAndCutAtCharacterBoundaries) {
  // 40 bytes of a header value used to be cut in the middle of a 3-byte character.
  const std::string euros = [] {
    std::string s;
    for (int i = 0; i < 30; ++i) s += "\xE2\x82\xAC";
    return s;
  }();
  const auto t = ReadTextTable("# format: x/1\n# n: " + euros + "\n# m: a[31m\nq\n1\n", "f");
  const auto e = Expect<InvalidInput>([&] { t.RequireNumber("n"); });
  EXPECT_TRUE(Utf8(e.what())) << e.what();
  EXPECT_EQ(e.line(), 2u);
  // A terminal escape in a header value is refused as the file is read, and shown escaped.
  const auto e2 = Expect<InvalidInput>(
      [&] { ReadTextTable("# format: x/1\n# m: a\x1b[31m\xE2\x80\xA8\nq\n1\n", "f"); });
  EXPECT_EQ(e2.line(), 2u);
  EXPECT_EQ(e2.field(), "m");
  EXPECT_FALSE(Contains(e2.what(), "\x1b")) << e2.what();
  EXPECT_FALSE(Contains(e2.what(), "\xE2\x80\xA8")) << e2.what();
  EXPECT_TRUE(Contains(e2.what(), "\\x1B")) << e2.what();
  EXPECT_TRUE(Contains(e2.what(), "\\u{2028}")) << e2.what();
  // A bad cell and a bad column-header row.
  const auto e3 = Expect<InvalidInput>(
      [&] { ReadTextTable("# format: x/1\nq,r\n1," + euros + "\x07\n", "f"); });
  EXPECT_EQ(e3.line(), 3u);
  EXPECT_EQ(e3.field(), "r");
  EXPECT_TRUE(Utf8(e3.what())) << e3.what();
  const auto e4 =
      Expect<InvalidInput>([&] { ReadTextTable("# format: x/1\nq," + euros + "\n", "f"); });
  EXPECT_TRUE(Utf8(e4.what())) << e4.what();
  // A control character inside a header value of a kind parser.
  const auto e5 = Expect<InvalidInput>([&] {
    ParseStraightnessFile(
        "# format: kinemetric-straightness/1\n# machine_id: m\n# axis: X\x1b\n"
        "# error_direction: Z\n# sensor: laser\n# reference: flat\nposition_mm,deviation_um\n"
        "0,0\n1,0\n2,0\n",
        "s.txt");
  });
  EXPECT_EQ(e5.field(), "axis");
  EXPECT_TRUE(Contains(e5.what(), "'X\\x1B'")) << e5.what();
  // NUL bytes name their line and column.
  const auto e6 = Expect<InvalidInput>(
      [&] { ReadTextTable(std::string("# format: x/1\nq\n1\n2\0\n", 21), "f"); });
  EXPECT_EQ(e6.line(), 4u) << e6.what();
  EXPECT_TRUE(Contains(e6.what(), "byte column 2")) << e6.what();
}

TEST(FormatLine, IsCheckedBeforeUse) {
  EXPECT_EQ(PeekFormat("\xEF\xBB\xBF\n  \n# format: kinemetric-dbb/1\r\n", "f"),
            "kinemetric-dbb/1");
  for (const std::string& bad :
       {std::string("# format: kinemetric-\xff/1\n"), std::string("# format: dbb\n"),
        std::string("# format: /1\n"), std::string("# format: a/b\n"),
        std::string("# format: a b/1\n"), std::string("# format: a/1\x1b[2J\n"),
        "# format: " + std::string(65, 'a') + "/1\n",
        "# format: a/1" + std::string(9000, ' ') + "x\n", std::string("x,y\n"),
        std::string(20'000, '\xff')}) {
    SCOPED_TRACE(Quote(bad, 30));
    for (int reader = 0; reader < 2; ++reader) {
      const auto e = Expect<InvalidInput>([&] {
        if (reader == 0) {
          PeekFormat(bad, "f");
        } else {
          ReadTextTable(bad + "q\n1\n", "f");
        }
      });
      EXPECT_TRUE(Utf8(e.what())) << e.what();
      EXPECT_LT(std::string(e.what()).size(), 400u) << e.what();
      if (reader == 0) {
        EXPECT_EQ(e.field(), "format") << e.what();
      }
    }
  }
}

// A table of `rows` rows "i,2i" with `head` header lines (format line included).
std::string Table(int rows, int head = 1) {
  std::string s = "# format: x/1\n";
  for (int i = 1; i < head; ++i) s += "# k" + std::to_string(i) + ": v\n";
  s += "a,b\n";
  for (int i = 0; i < rows; ++i) s += std::to_string(i) + "," + std::to_string(2 * i) + "\n";
  return s;
}

TEST(Limits, EachIsRefusedAtTheFirstLineBeyondIt) {
  ReadOptions o;
  o.max_rows = 10;
  o.max_line_bytes = 32;
  o.max_columns = 3;
  o.max_cells = 18;
  o.max_header_lines = 4;
  o.max_markers = 2;
  EXPECT_EQ(ReadTextTable(Table(9, 4), "f", o).NumRows(), 9u);
  struct Case {
    std::string text;
    std::size_t line;
    std::string words;
  };
  const Case cases[] = {
      {Table(10, 1), 2 + 10, "18 data values"},  // the cells, before the rows
      {Table(11, 5), 5, "4 '#' lines"},          // header lines
      {"# format: x/1\na,b,c,d\n1,2,3,4\n", 2, "4 columns; the limit is 3"},
      {"# format: x/1\na,b\n1," + std::string(40, '1') + "\n" + std::string(1 << 20, '2'), 3,
       "longer than 32 bytes"},
      {"# format: x/1\na,b\n1,2\n# m: 1\n3,4\n# m: 2\n# m: 3\n5,6\n", 7, "2 '#' lines among"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.words);
    for (int reader = 0; reader < 2; ++reader) {
      const auto e = Expect<TooLarge>([&] {
        if (reader == 0) {
          ReadTextTable(c.text, "f", o);
        } else {
          CheckTextLimits(c.text, "f", o);
        }
      });
      EXPECT_EQ(e.file(), "f");
      EXPECT_EQ(e.line(), c.line) << e.what();
      EXPECT_TRUE(Contains(e.what(), c.words)) << e.what();
    }
  }
  o.max_cells = SIZE_MAX;
  const auto e = Expect<TooLarge>([&] { ReadTextTable(Table(11), "f", o); });
  EXPECT_EQ(e.line(), 2u + 11u);
  EXPECT_TRUE(Contains(e.what(), "more than 10 data rows")) << e.what();
  // A line of exactly the limit, with a CR LF line break, is accepted; one byte more is not.
  o.max_line_bytes = 13;
  EXPECT_EQ(ReadTextTable("# format: x/1\r\na,b\r\n123,4\r\n", "f", o).NumRows(), 1u);
  EXPECT_EQ(ReadTextTable("# format: x/1\na,b\n123,4", "f", o).NumRows(), 1u);
  EXPECT_THROW(ReadTextTable("# format: xy/1\r\na,b\r\n123,4\r\n", "f", o), TooLarge);
  o.max_bytes = 10;
  EXPECT_THROW(ReadTextTable(Table(1), "f", o), TooLarge);
}

TEST(Limits, KindParsersHaveCeilings) {
  EXPECT_EQ(DefaultFormLimits().max_rows, 1'000'000u);
  EXPECT_EQ(DefaultTrackerLimits().max_rows, 200'000u);
  TextLimits l = DefaultFormLimits();
  l.max_rows = 3;
  const std::string s =
      "# format: kinemetric-parallelism/1\n# machine_id: m\n# axis: X\n# datum: table\n"
      "position_mm,deviation_um\n0,0\n1,0\n2,0\n3,0\n";
  EXPECT_EQ(ParseParallelismFile(s, "p.txt").profile.position_mm.size(), 4u);
  const auto e = Expect<TooLarge>([&] { ParseParallelismFile(s, "p.txt", l); });
  EXPECT_EQ(e.line(), 9u);
}

TEST(Columns, KeptByColumnRowLinesByRuns) {
  ReadOptions o;
  o.keep_column = [](std::string_view c) { return c != "skip"; };
  const std::string text =
      "# format: x/1\n"  // 1
      "a,skip,b\n"       // 2
      "1,9,2\n"          // 3
      "3,9,4\n"          // 4
      "\n"               // 5
      "# m: x\n"         // 6
      "5,9,6\n"          // 7
      "7,9,8\n";         // 8
  const auto t = ReadTextTable(text, "f", o);
  ASSERT_EQ(t.NumRows(), 4u);
  EXPECT_EQ(t.Column(0), (std::vector<double>{1, 3, 5, 7}));
  EXPECT_EQ(t.Column(2), (std::vector<double>{2, 4, 6, 8}));
  EXPECT_TRUE(t.values[1].empty());
  EXPECT_THROW(t.Column(1), std::out_of_range);
  EXPECT_EQ(t.Row(2)[2], 6.0);
  EXPECT_EQ(t.values[0].capacity(), 4u);  // allocated once, to size
  EXPECT_EQ(t.row_lines.size(), 4u);
  EXPECT_EQ(t.row_lines.runs(), 2u);
  EXPECT_EQ(t.row_lines[0], 3u);
  EXPECT_EQ(t.row_lines[1], 4u);
  EXPECT_EQ(t.row_lines[2], 7u);
  EXPECT_EQ(t.row_lines[3], 8u);
  EXPECT_EQ(t.row_lines.back(), 8u);
  ASSERT_EQ(t.markers.size(), 1u);
  EXPECT_EQ(t.markers[0].before_row, 2u);
  // A column that is not kept is checked all the same.
  const auto e =
      Expect<InvalidInput>([&] { ReadTextTable("# format: x/1\na,skip\n1,x\n", "f", o); });
  EXPECT_EQ(e.field(), "skip");
  EXPECT_EQ(e.line(), 3u);
}

TEST(KindParsers, RepeatedPointsNameTheFirstRepeatInFileOrder) {
  // Flatness: (0,0) repeats on line 7 (first on line 4) before (1,1) repeats on line 8.
  const std::string flat =
      "# format: kinemetric-flatness/1\n# machine_id: m\nx_mm,y_mm,z_um\n"
      "0,0,1\n1,1,1\n2,0,1\n0,0,2\n1,1,3\n0,0,5\n";
  const auto e = Expect<InvalidInput>([&] { ParseFlatnessFile(flat, "f.txt"); });
  EXPECT_EQ(e.line(), 7u) << e.what();
  EXPECT_TRUE(Contains(e.what(), "line 4")) << e.what();
  // Tracker: point 3 repeats on line 10 (first on line 8); a bad id before it is reported first.
  const std::string head =
      "# format: kinemetric-tracker/1\n# machine_id: m\n# trackers: 4\n# mode: simultaneous\n"
      "point,x_mm,y_mm,z_mm,d1_um,d2_um,d3_um,d4_um\n";
  const std::string rows = "1,0,0,0,0,0,0,0\n3,1,0,0,1,1,1,1\n2,0,1,0,1,1,1,1\n3,0,0,1,1,1,1,1\n";
  const auto e2 =
      Expect<InvalidInput>([&] { ParseTrackerFile(head + "5,0,0,0,0,0,0,0\n" + rows, "t.txt"); });
  EXPECT_EQ(e2.line(), 10u) << e2.what();
  EXPECT_TRUE(Contains(e2.what(), "first on line 8")) << e2.what();
  const auto e3 =
      Expect<InvalidInput>([&] { ParseTrackerFile(head + "1.5,0,0,0,0,0,0,0\n" + rows, "t.txt"); });
  EXPECT_EQ(e3.line(), 6u) << e3.what();
  EXPECT_EQ(e3.field(), "point");
}

}  // namespace
}  // namespace km::ingest
