// Parser of kinemetric-servo/1 (ingest/servo_parser.h): good hexapod and feed-drive files,
// currents with force constants, and every kind of bad input an InvalidInput naming file, line
// and field.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/servo_parser.h"

namespace km::ingest {
namespace {

const std::string kHexapod =
    "# format: kinemetric-servo/1\n"                            // 1
    "# machine_id: pm600-like\n"                                // 2
    "# test_id: s01\n"                                          // 3
    "# motion: circle\n"                                        // 4
    "# direction: ccw\n"                                        // 5
    "# tool_length_mm: 104.255\n"                               // 6
    "# force_unit: N\n"                                         // 7
    "t_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,f1,f2,f3,f4,f5,f6\n"  // 8
    "0,150,0,-1150,0,0,0,1,2,3,4,5,6\n"                         // 9
    "0.1,149.9,1.7,-1150,0,0,0,1,2,3,4,5,6\n"                   // 10
    "0.2,149.6,3.4,-1150,0,0,0,1,2,3,4,5,6\n"                   // 11
    "0.3,149.2,5.1,-1150,0,0,0,1,2,3,4,5,6\n"                   // 12
    "0.4,148.7,6.8,-1150,0,0,0,1,2,3,4,5,6\n";                  // 13

const std::string kSerial =
    "# format: kinemetric-servo/1\n"       // 1
    "# machine_id: vmc\n"                  // 2
    "# test_id: x-strokes\n"               // 3
    "# motion: path\n"                     // 4
    "# axis: x\n"                          // 5
    "# force_unit: current_A\n"            // 6
    "# force_constant_N_per_A: 50, 40\n"   // 7
    "t_s,pos_mm,force,pos_y_mm,force_y\n"  // 8
    "0,0,1,5,2\n"                          // 9
    "0.1,1,1,5,2\n"                        // 10
    "0.2,2,1,5,2\n"                        // 11
    "0.3,3,1,5,2\n"                        // 12
    "0.4,4,-1,5,2\n";                      // 13

std::string Edit(const std::string& base, const std::string& from, const std::string& to) {
  std::string s = base;
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  s.replace(at, from.size(), to);
  return s;
}

void ExpectBad(const std::string& text, std::size_t line, const std::string& field) {
  try {
    ParseServoFile(text, "s.txt");
    ADD_FAILURE() << "accepted (expected line " << line << ", field " << field << ")";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "s.txt") << e.what();
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.field(), field) << e.what();
  }
}

TEST(ServoParser, ReadsAHexapodFile) {
  const auto f = ParseServoFile(kHexapod, "s.txt");
  EXPECT_TRUE(f.hexapod);
  EXPECT_EQ(f.machine_id, "pm600-like");
  EXPECT_EQ(f.test_id, "s01");
  EXPECT_EQ(f.direction, "ccw");
  EXPECT_DOUBLE_EQ(f.tool_length_mm, 104.255);
  ASSERT_EQ(f.samples.size(), 5u);
  EXPECT_DOUBLE_EQ(f.samples[1].tip_mm[1], 1.7);
  EXPECT_DOUBLE_EQ(f.samples[4].force_N[5], 6.0);
  EXPECT_EQ(f.lines[4], 13u);
}

TEST(ServoParser, ReadsAFeedDriveFileInCurrents) {
  const auto f = ParseServoFile(kSerial, "s.txt");
  EXPECT_FALSE(f.hexapod);
  ASSERT_EQ(f.axes.size(), 2u);
  EXPECT_EQ(f.axes[0].axis, "X");
  EXPECT_EQ(f.axes[1].axis, "Y");
  EXPECT_DOUBLE_EQ(f.axes[0].force_N[4], -50.0);
  EXPECT_DOUBLE_EQ(f.axes[1].force_N[0], 80.0);
  EXPECT_EQ(f.direction, "");
}

TEST(ServoParser, HexapodCurrentsNeedSixConstants) {
  const std::string amps = Edit(kHexapod, "# force_unit: N\n",
                                "# force_unit: current_A\n# force_constant_N_per_A: 1,2,3,4,5,6\n");
  const auto f = ParseServoFile(amps, "s.txt");
  EXPECT_DOUBLE_EQ(f.samples[0].force_N[2], 9.0);
  ExpectBad(Edit(kHexapod, "# force_unit: N\n", "# force_unit: current_A\n"), 7,
            "force_constant_N_per_A");
  ExpectBad(Edit(kHexapod, "# force_unit: N\n",
                 "# force_unit: current_A\n# force_constant_N_per_A: 1,2,3\n"),
            8, "force_constant_N_per_A");
  ExpectBad(Edit(kHexapod, "# force_unit: N\n",
                 "# force_unit: current_A\n# force_constant_N_per_A: 1,2,3,4,5,-6\n"),
            8, "force_constant_N_per_A");
}

TEST(ServoParser, RefusesBadInputNamingLineAndField) {
  ExpectBad(Edit(kHexapod, "kinemetric-servo/1", "kinemetric-dbb/1"), 1, "format");
  ExpectBad(Edit(kHexapod, "# machine_id: pm600-like\n", ""), 0, "machine_id");
  ExpectBad(Edit(kHexapod, "# motion: circle", "# motion: spiral"), 4, "motion");
  ExpectBad(Edit(kHexapod, "# direction: ccw\n", ""), 0, "direction");
  ExpectBad(Edit(kHexapod, "# direction: ccw", "# direction: up"), 5, "direction");
  ExpectBad(Edit(kHexapod, "# force_unit: N", "# force_unit: kgf"), 7, "force_unit");
  ExpectBad(Edit(kHexapod, "# tool_length_mm: 104.255\n", ""), 0, "tool_length_mm");
  ExpectBad(Edit(kHexapod, "# tool_length_mm: 104.255", "# tool_length_mm: -3"), 6,
            "tool_length_mm");
  ExpectBad(Edit(kHexapod, ",f5,f6\n", ",f5,g6\n"), 8, "f6");
  ExpectBad(Edit(kHexapod, "0.2,149.6", "0.1,149.6"), 11, "t_s");
  ExpectBad(Edit(kHexapod, "0.3,149.2,5.1", "0.3,149.2,abc"), 12, "y_mm");
  ExpectBad(Edit(kHexapod, "0.3,149.2,5.1,-1150,0,0,0", "0.3,149.2,5.1,-1150,0,720,0"), 12,
            "b_deg");
  ExpectBad(Edit(kHexapod, "0.4,148.7,6.8,-1150,0,0,0,1,2,3,4,5,6\n",
                 "0.4,148.7,6.8,-1150,0,0,0,1,2,3,4,5,1e9\n"),
            13, "f6");
  // Too few rows.
  const std::string short_file = kHexapod.substr(0, kHexapod.find("0.3,149.2"));
  ExpectBad(short_file, 11, "t_s");
}

TEST(ServoParser, RefusesBadFeedDriveInput) {
  ExpectBad(Edit(kSerial, "# axis: x", "# axis: q"), 5, "axis");
  ExpectBad(Edit(kSerial, "t_s,pos_mm,force,", "t_s,pos_mm,load,"), 8, "force");
  ExpectBad(Edit(kSerial, ",pos_y_mm,force_y", ",pos_y_mm,load_y"), 8, "force_y");
  ExpectBad(Edit(kSerial, "pos_y_mm,force_y", "pos_x_mm,force_x"), 8, "pos_x_mm");
  ExpectBad(Edit(kSerial, "# force_constant_N_per_A: 50, 40", "# force_constant_N_per_A: 50"), 7,
            "force_constant_N_per_A");
  ExpectBad(Edit(kSerial, "0.2,2,1,5,2", "0.2,2,1,5,"), 11, "force_y");
}

// A feed-drive record of `n` samples every `dt` s moving at `speed` mm/s from 0; `jump_mm` added
// to every position from sample `at` on (two recordings joined).
std::string Stroke(int n, double dt, double speed, int at = -1, double jump_mm = 0.0,
                   const std::vector<double>& times = {}) {
  std::string s =
      "# format: kinemetric-servo/1\n# machine_id: vmc\n# test_id: x\n# motion: path\n"
      "# axis: X\n# force_unit: N\nt_s,pos_mm,force\n";  // rows from line 8
  char buf[96];
  for (int i = 0; i < n; ++i) {
    const double t = times.empty() ? i * dt : times[static_cast<std::size_t>(i)];
    const double x = speed * t + (at >= 0 && i >= at ? jump_mm : 0.0);
    std::snprintf(buf, sizeof buf, "%.6f,%.6f,%.3f\n", t, x, 30.0);
    s += buf;
  }
  return s;
}

TEST(ServoParser, RefusesJoinedRecordingsNamingTheJump) {
  // 40 mm/s sampled every 2 ms; the position jumps 100 mm between the rows on lines 27 and 28.
  const std::string joined = Stroke(50, 0.002, 40.0, 20, 100.0);
  ExpectBad(joined, 28, "pos_mm");
  try {
    ParseServoFile(joined, "joined.txt");
  } catch (const InvalidInput& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("joined.txt:28: field 'pos_mm'"), std::string::npos) << what;
    EXPECT_NE(what.find("jumps by 100.080 mm in 2.000 ms from line 27"), std::string::npos) << what;
    EXPECT_NE(what.find("two recordings joined"), std::string::npos) << what;
  }
  // Backwards too, and a glitch of one sample (the first jump is named).
  ExpectBad(Stroke(50, 0.002, 40.0, 30, -55.5), 38, "pos_mm");
  ExpectBad(Edit(Stroke(50, 0.002, 40.0), "0.020000,0.800000", "0.020000,1.800000"), 18, "pos_mm");
  // A hexapod's tool-tip position: the same.
  ExpectBad(Edit(kHexapod, "0.3,149.2,5.1", "0.3,149.2,305.1"), 12, "y_mm");
}

TEST(ServoParser, KeepsMotionThatOnlyLooksUneven) {
  // A start from rest, a fast stroke at 1 kHz, a pause of the logger (one long interval at the
  // same speed), time stamps rounded to the millisecond at 1.7 ms, a short move at 10 Hz.
  EXPECT_NO_THROW(ParseServoFile(Stroke(40, 0.001, 500.0), "fast.txt"));
  std::vector<double> paused;
  for (int i = 0; i < 40; ++i) paused.push_back(i < 20 ? 0.002 * i : 0.002 * i + 1.5);
  EXPECT_NO_THROW(ParseServoFile(Stroke(40, 0.002, 40.0, -1, 0.0, paused), "paused.txt"));
  std::vector<double> rounded;
  for (int i = 0; i < 40; ++i) rounded.push_back(std::round(1.7 * i) * 1e-3);
  std::string jitter = Stroke(40, 0.0017, 40.0);  // positions at the true times…
  std::string stamped = Stroke(40, 0.0017, 40.0, -1, 0.0, rounded);  // …times rounded
  const auto rows = [](const std::string& s) { return s.substr(s.find("t_s,")); };
  std::string mixed = stamped.substr(0, stamped.find("t_s,")) + "t_s,pos_mm,force\n";
  {
    std::istringstream a(rows(jitter)), b(rows(stamped));
    std::string la, lb;
    std::getline(a, la);
    std::getline(b, lb);
    while (std::getline(a, la) && std::getline(b, lb))
      mixed += lb.substr(0, lb.find(',')) + la.substr(la.find(',')) + "\n";
  }
  EXPECT_NO_THROW(ParseServoFile(mixed, "rounded.txt"));
  std::string rest_then_move = Stroke(10, 0.1, 0.0);
  rest_then_move = Edit(rest_then_move, "0.500000,0.000000", "0.500000,0.100000");
  rest_then_move = Edit(rest_then_move, "0.600000,0.000000", "0.600000,0.100000");
  EXPECT_NO_THROW(ParseServoFile(rest_then_move, "short-move.txt"));
}

}  // namespace
}  // namespace km::ingest
