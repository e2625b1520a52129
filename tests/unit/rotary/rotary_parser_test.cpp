// The R-test file `kinemetric-rotary/1` (docs/formats.md §1.10): a good file read, and every bad
// one refused naming file, line and field.
#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"
#include "ingest/rotary/rotary_parser.h"
#include "tests/unit/expect_error.h"

namespace km::ingest {
namespace {

// Header lines 1–10, the column row on line 11, poses from line 12.
std::string Header(const std::string& kinematics = "AC-trunnion",
                   const std::string& axis = "# a_axis_mm: 0, 60\n") {
  return "# format: kinemetric-rotary/1\n# machine_id: m5\n# test_id: r1\n"
         "# timestamp: 2026-03-01T10:00:00Z\n# kinematics: " +
         kinematics + "\n" + axis +
         "# c_axis_mm: 1.5, -2\n# sphere_mm: 150, 20, 120\n# u_reading_um: 0.5\n"
         "# instrument: R-test\n";
}

const std::string kRows = "0,0,0,0,0\n0,90,1.2,-0.4,0.1\n45,0,0.3,2.5,-1\n-45,180,-0.7,0.2,0.9\n";

std::string Ac(const std::string& rows = kRows,
               const std::string& columns = "a_deg,c_deg,dx_um,dy_um,dz_um\n") {
  return Header() + columns + rows;
}

InvalidInput Refused(const std::string& text) {
  return test::Expect<InvalidInput>([&] { ParseRotaryFile(text, "r.txt"); });
}

void ExpectRefused(const std::string& text, std::size_t line, const std::string& field) {
  const InvalidInput e = Refused(text);
  EXPECT_EQ(e.file(), "r.txt") << e.what();
  EXPECT_EQ(e.line(), line) << e.what();
  EXPECT_EQ(e.field(), field) << e.what();
}

TEST(RotaryParser, ReadsAGoodFile) {
  const RotaryFile f = ParseRotaryFile(Ac(), "r.txt");
  EXPECT_EQ(f.machine_id, "m5");
  EXPECT_EQ(f.test_id, "r1");
  EXPECT_EQ(f.test.setup.kinematics, rotary::Kinematics::kAcTrunnion);
  EXPECT_EQ(f.test.setup.tilt_axis_mm[1], 60.0);
  EXPECT_EQ(f.test.setup.c_axis_mm[0], 1.5);
  EXPECT_EQ(f.test.setup.sphere_mm[2], 120.0);
  ASSERT_EQ(f.test.poses.size(), 4u);
  EXPECT_EQ(f.test.poses[2].tilt_deg, 45.0);
  EXPECT_EQ(f.test.poses[3].c_deg, 180.0);
  EXPECT_EQ(f.test.poses[1].d_um[1], -0.4);
  EXPECT_EQ(f.lines[3], 15u);
  EXPECT_EQ(f.u_reading_um, 0.5);
  EXPECT_TRUE(f.time_s.empty());
  const RotaryFile b = ParseRotaryFile(
      Header("bc-trunnion", "# b_axis_mm: -5, 60\n") + "c_deg,b_deg,dx_um,dy_um,dz_um,time_s\n" +
          "0,0,0,0,0,0\n90,0,1,2,3,1\n0,30,1,2,3,2\n180,-30,1,2,3,3\n",
      "b.txt");
  EXPECT_EQ(b.test.setup.kinematics, rotary::Kinematics::kBcTrunnion);
  EXPECT_EQ(b.test.poses[2].tilt_deg, 30.0);
  EXPECT_EQ(b.test.poses[1].c_deg, 90.0);
  EXPECT_EQ(b.time_s.size(), 4u);
}

TEST(RotaryParser, RefusesBadHeaders) {
  ExpectRefused(Header("AB-trunnion") + "a_deg,c_deg,dx_um,dy_um,dz_um\n" + kRows, 5, "kinematics");
  // An AC file without its A line; a BC file given the A line.
  ExpectRefused(Header("AC-trunnion", "") + "a_deg,c_deg,dx_um,dy_um,dz_um\n" + kRows, 5,
                "a_axis_mm");
  ExpectRefused(Header("BC-trunnion") + "b_deg,c_deg,dx_um,dy_um,dz_um\n" + kRows, 6, "a_axis_mm");
  ExpectRefused(
      Header("AC-trunnion", "# a_axis_mm: 0, nan\n") + "a_deg,c_deg,dx_um,dy_um,dz_um\n" + kRows, 6,
      "a_axis_mm");
  ExpectRefused(
      Header("AC-trunnion", "# a_axis_mm: 0, 60, 1\n") + "a_deg,c_deg,dx_um,dy_um,dz_um\n" + kRows,
      6, "a_axis_mm");
  // A key given twice, a bad reading uncertainty, a missing sphere, a bad timestamp.
  ExpectRefused("# format: kinemetric-rotary/1\n# machine_id: m5\n# machine_id: m6\n" +
                    Header().substr(30) + "a_deg,c_deg,dx_um,dy_um,dz_um\n" + kRows,
                3, "machine_id");
  std::string text = Ac();
  text.replace(text.find("u_reading_um: 0.5"), 17, "u_reading_um: 500");
  ExpectRefused(text, 9, "u_reading_um");
  text = Ac();
  text.replace(text.find("# sphere_mm: 150, 20, 120\n"), 26, "");
  ExpectRefused(text, 0, "sphere_mm");
  text = Ac();
  text.replace(text.find("2026-03-01T10:00:00Z"), 20, "yesterday");
  ExpectRefused(text, 4, "timestamp");
}

TEST(RotaryParser, RefusesTheWrongColumns) {
  ExpectRefused(Ac(kRows, "b_deg,c_deg,dx_um,dy_um,dz_um\n"), 11, "b_deg");
  ExpectRefused(Ac("0,0,0,0,0,0\n0,90,1,2,3,0\n45,0,1,2,3,0\n-45,180,1,2,3,0\n",
                   "a_deg,c_deg,dx_um,dy_um,dz_um,dw_um\n"),
                11, "dw_um");
  ExpectRefused(Ac("0,0,0,0\n0,90,1,2\n45,0,1,2\n-45,1,2,3\n", "a_deg,c_deg,dx_um,dy_um\n"), 11,
                "dz_um");
}

TEST(RotaryParser, RefusesBadPoses) {
  // Not a number, an infinite one, a displacement beyond 10 mm, an absurd angle.
  ExpectRefused(Ac("0,0,0,0,0\n0,90,1.2,x,0.1\n45,0,0.3,2.5,-1\n-45,180,-0.7,0.2,0.9\n"), 13,
                "dy_um");
  ExpectRefused(Ac("0,0,0,0,0\n0,90,1.2,1,inf\n45,0,0.3,2.5,-1\n-45,180,-0.7,0.2,0.9\n"), 13,
                "dz_um");
  ExpectRefused(Ac("0,0,0,0,0\n0,90,1.2,1,1\n45,0,0.3,2.5e5,-1\n-45,180,-0.7,0.2,0.9\n"), 14,
                "dy_um");
  ExpectRefused(Ac("0,0,0,0,0\n0,90,1.2,1,1\n45,0,0.3,2.5,-1\n-4500,180,-0.7,0.2,0.9\n"), 15,
                "a_deg");
  // The first pose not at zero angles.
  ExpectRefused(Ac("0,90,1.2,1,1\n0,0,0,0,0\n45,0,0.3,2.5,-1\n-45,180,-0.7,0.2,0.9\n"), 12,
                "c_deg");
  ExpectRefused(Ac("10,0,1.2,1,1\n0,0,0,0,0\n45,0,0.3,2.5,-1\n-45,180,-0.7,0.2,0.9\n"), 12,
                "a_deg");
  // Too few poses to determine anything with a residual left.
  ExpectRefused(Ac("0,0,0,0,0\n0,90,1.2,1,1\n45,0,0.3,2.5,-1\n"), 14, "poses");
}

}  // namespace
}  // namespace km::ingest
