// What names and header values may hold (ingest/identifiers.h): line breaks of every kind,
// controls and invisible formatting characters are refused in every header value of every
// format; a machine id also fits one URL path segment.
#include "ingest/identifiers.h"

#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"
#include "ingest/dbb_parser.h"
#include "ingest/form_parsers.h"
#include "tests/unit/expect_error.h"

namespace km::ingest {
namespace {

using km::test::Expect;

TEST(Identifiers, MachineIds) {
  for (const char* ok : {"vmc-3axis", "Halle 2", "Fräse_7", "m.1", "a b", "x:y"}) {
    EXPECT_FALSE(MachineIdProblem(ok)) << ok;
  }
  for (const std::string& bad :
       {std::string(), std::string("."), std::string(".."), std::string("a/b"), std::string("a\\b"),
        std::string("a\rb"), std::string("a\x0B"), std::string("a\x0C"), std::string("a\x7F"),
        std::string("a\xC2\x85"), std::string("a\xE2\x80\xA8"), std::string("a\xE2\x80\xA9"),
        std::string("a\xE2\x80\xAE"), std::string("a\xE2\x81\xA6"),
        std::string("\xEF\xBB\xBF"
                    "a"),
        std::string("a\x80"), std::string("a\tb"), std::string(257, 'm'), std::string("a\0b", 3)}) {
    EXPECT_TRUE(MachineIdProblem(bad)) << "accepted: " << bad;
  }
  EXPECT_FALSE(MachineIdProblem(std::string(256, 'm')));
}

TEST(Identifiers, ControllerSafeAlphabet) {
  EXPECT_TRUE(IsControllerSafe("vmc-3axis"));
  EXPECT_TRUE(IsControllerSafe("X"));
  EXPECT_TRUE(IsControllerSafe("m1.a:b_c"));
  for (const std::string& bad : {std::string(), std::string("a b"), std::string("a;b"),
                                 std::string("a\rb"), std::string("Fräse"), std::string("a$b"),
                                 std::string("a=b"), std::string("(a)"), std::string(65, 'a')}) {
    EXPECT_FALSE(IsControllerSafe(bad)) << bad;
  }
}

std::string Dbb(const std::string& machine_id, const std::string& test_id = "xy-r150") {
  std::string text =
      "# format: kinemetric-dbb/1\n# machine_id: " + machine_id + "\n# test_id: " + test_id +
      "\n# direction: cw\n# plane: XY\n# bar_length_mm: 150\n# radius_mm: 150\n"
      "# centre_mm: 0, 0, 0\n# z_offset_mm: 0\n# feed_mm_min: 1000\n# tilt_deg: 0, 0, 0\n"
      "angle_deg,dr_um\n";
  for (int a = 0; a < 360; a += 10) text += std::to_string(-a) + ",0.5\n";
  return text;
}

TEST(Identifiers, EveryFormatRefusesLineBreaksInHeaderValues) {
  EXPECT_NO_THROW(ParseDbb(Dbb("vmc"), "t.txt"));
  const auto e = Expect<InvalidInput>([] { ParseDbb(Dbb("vmc\rM30"), "t.txt"); });
  EXPECT_EQ(e.file(), "t.txt");
  EXPECT_EQ(e.line(), 2u);
  EXPECT_EQ(e.field(), "machine_id");
  EXPECT_NE(std::string(e.what()).find("carriage return"), std::string::npos) << e.what();
  const auto t = Expect<InvalidInput>([] {
    ParseDbb(Dbb("vmc",
                 "a\xC2\x85"
                 "b"),
             "t.txt");
  });
  EXPECT_EQ(t.line(), 3u);
  EXPECT_EQ(t.field(), "test_id");
  const auto slash = Expect<InvalidInput>([] { ParseDbb(Dbb("plant/vmc"), "t.txt"); });
  EXPECT_EQ(slash.field(), "machine_id");
  EXPECT_NE(std::string(slash.what()).find("'/'"), std::string::npos) << slash.what();
  const std::string flat =
      "# format: kinemetric-flatness/1\n# machine_id: a\xE2\x80\xA8"
      "b\nx_mm,y_mm,z_um\n0,0,1\n";
  const auto f = Expect<InvalidInput>([&] { ParseFlatnessFile(flat, "f.txt"); });
  EXPECT_EQ(f.line(), 2u);
  EXPECT_EQ(f.field(), "machine_id");
}

}  // namespace
}  // namespace km::ingest
