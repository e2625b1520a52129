#include "ingest/dbb_parser.h"

#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"

namespace km::ingest {
namespace {

std::string Header(const std::string& extra = "") {
  return "# format: kinemetric-dbb/1\n"
         "# machine_id: vmc-1\n"
         "# test_id: xy-150\n"
         "# direction: ccw\n"
         "# bar_length_mm: 150\n"
         "# centre_mm: 10, 20, 30\n"
         "# feed_mm_min: 1000\n" +
         extra;
}

std::string Rows(int n = 36, double step = 10.0, double start = 0.0) {
  std::string s = "angle_deg,dr_um\n";
  for (int i = 0; i < n; ++i) {
    s += std::to_string(start + step * i) + "," + std::to_string(0.1 * (i % 5)) + "\n";
  }
  return s;
}

// Expects InvalidInput with the given line (0 = any) and field.
void ExpectError(const std::string& text, std::size_t line, const std::string& field,
                 const std::string& fragment = "") {
  try {
    ParseDbb(text, "test.dbb");
    FAIL() << "no error for field " << field;
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "test.dbb");
    if (line) {
      EXPECT_EQ(e.line(), line) << e.what();
    }
    EXPECT_EQ(e.field(), field) << e.what();
    if (!fragment.empty()) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  }
}

TEST(DbbParser, ReadsAValidFile) {
  const auto t = ParseDbb(
      Header("# plane: YZ\n# owner: lab 3\n# fixed_ball_mm: 1, 2, 3\n") + Rows(), "ok.dbb");
  EXPECT_EQ(t.machine_id, "vmc-1");
  EXPECT_EQ(t.test_id, "xy-150");
  EXPECT_EQ(t.direction, dbb::Direction::kCcw);
  EXPECT_EQ(t.plane, dbb::Plane::kYZ);
  EXPECT_DOUBLE_EQ(t.radius_mm, 150.0);  // defaults to the bar length
  EXPECT_DOUBLE_EQ(t.centre_mm[2], 30.0);
  ASSERT_TRUE(t.fixed_ball_mm.has_value());
  EXPECT_DOUBLE_EQ((*t.fixed_ball_mm)[1], 2.0);
  EXPECT_EQ(t.metadata.at("owner"), "lab 3");  // unknown keys are kept
  EXPECT_EQ(t.angle_deg.size(), 36u);
  EXPECT_DOUBLE_EQ(t.dr_um[3], 0.3);
}

TEST(DbbParser, TimeColumnGivesAnglesFromFeedAndRadius) {
  // 1000 mm/min on R = 150 mm: ω = 1000/60/150 rad/s; one turn takes 2π·150·60/1000 s.
  const double turn_s = 2 * 3.14159265358979 * 150.0 * 60.0 / 1000.0;
  std::string rows = "t_s,dr_um\n";
  for (int i = 0; i < 72; ++i) rows += std::to_string(turn_s * i / 72) + ",0\n";
  const auto t = ParseDbb(Header("# start_angle_deg: 90\n") + rows, "t.dbb");
  EXPECT_NEAR(t.angle_deg[0], 90.0, 1e-9);
  EXPECT_NEAR(t.angle_deg[36], 270.0, 1e-3);
}

TEST(DbbParser, BadInputNamesFileLineAndField) {
  ExpectError("# format: kinemetric-foo/1\n" + Rows(), 1, "format", "unknown format");
  ExpectError("angle_deg,dr_um\n0,0\n", 1, "format");
  // Missing required key: no line of its own, the field names it.
  ExpectError(
      "# format: kinemetric-dbb/1\n# machine_id: m\n# direction: ccw\n"
      "# bar_length_mm: 150\n# centre_mm: 0,0,0\n# feed_mm_min: 1000\n" +
          Rows(),
      0, "test_id", "missing");
  ExpectError(Header("# machine_id: again\n") + Rows(), 8, "machine_id", "duplicated");
  ExpectError(
      Header("# direction: up\n").replace(Header().find("# direction: ccw\n"), 17, "") + Rows(), 0,
      "direction");
  ExpectError(Header("# radius_mm: -3\n") + Rows(), 8, "radius_mm", "greater than zero");
  ExpectError(Header("# fixed_ball_mm: 1, 2\n") + Rows(), 8, "fixed_ball_mm", "3");
  ExpectError(Header("# timestamp: yesterday\n") + Rows(), 8, "timestamp");
  std::string bad = Header() + Rows();
  bad.replace(bad.find("\n20.000000,0.200000"), 19, "\n20.000000,abc");
  ExpectError(bad, 11, "dr_um", "not a finite");
  std::string nan = Header() + Rows();
  nan.replace(nan.find("\n30.000000,0.300000"), 19, "\n30.000000,nan");
  ExpectError(nan, 12, "dr_um");
  std::string inf = Header() + Rows();
  inf.replace(inf.find("\n30.000000,0.300000"), 19, "\n30.000000,inf");
  ExpectError(inf, 12, "dr_um");
  std::string big = Header() + Rows();
  big.replace(big.find("\n40.000000,0.400000"), 19, "\n40.000000,1e999");
  ExpectError(big, 13, "dr_um");
  // Changed deliberately (partial arcs): 190° without arc_deg is a partial arc now; declared as
  // a full turn it is refused, and 140° is too short for a partial arc.
  ExpectError(Header("# arc_deg: 360\n") + Rows(20, 10.0), 0, "angle_deg", "full turn");
  ExpectError(Header() + Rows(15, 10.0), 0, "angle_deg", "partial arc");
  std::string back = Header() + Rows();
  back.replace(back.find("\n50.000000"), 10, "\n15.000000");
  ExpectError(back, 14, "angle_deg", "increase");
  // cw files must decrease.
  std::string cw = Header() + Rows();
  cw.replace(cw.find("ccw"), 3, "cw");
  ExpectError(cw, 10, "angle_deg", "decrease");
  ExpectError(Header() + "angle_deg,dr_um\n0,1,2\n", 9, "", "expected 2 values");
  ExpectError(Header() + "angle_deg,x_um\n0,1\n", 8, "dr_um", "missing");
  ExpectError(Header() + "angle_deg,dr_um\n", 8, "dr_um", "no data rows");
  ExpectError(Header("this is not a header\n") + Rows(), 8, "");
}

TEST(DbbParser, RefusesOversizedFiles) {
  DbbParseOptions o;
  o.max_bytes = 500;
  try {
    ParseDbb(Header() + Rows(), "big.dbb", o);
    FAIL();
  } catch (const TooLarge& e) {
    EXPECT_NE(std::string(e.what()).find("limit"), std::string::npos);
  }
}

TEST(DbbParser, RefusesNonUtf8AndBinary) {
  ExpectError(Header("# owner: \xff\xfe\n") + Rows(), 8, "");
  std::string nul = Header() + Rows();
  nul[nul.size() - 3] = '\0';
  ExpectError(nul, 0, "");
}

}  // namespace
}  // namespace km::ingest
