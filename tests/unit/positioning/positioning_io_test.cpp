// The kinemetric-positioning/1 parser (errors name file, line and field) and the compensation
// tables: applying the exported LinuxCNC table to the measured data removes the systematic
// deviation (E after compensation ≤ R of the data), the signs from first principles, the
// SINUMERIK even grid.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/positioning/figures.h"
#include "ingest/positioning_parser.h"
#include "tests/unit/expect_error.h"
#include "tests/unit/positioning/positioning_sim.h"
#include "usecases/positioning_export.h"
#include "usecases/positioning_report.h"

namespace km::positioning {
namespace {

using km::test::Contains;
using km::test::Expect;

const char* kHeader =
    "# format: kinemetric-positioning/1\n"     // line 1
    "# machine_id: m1\n"                       // 2
    "# axis: X\n"                              // 3
    "# cycle: linear\n"                        // 4
    "# datum_mm: 0\n"                          // 5
    "# air_compensated: yes\n"                 // 6
    "run,direction,target_mm,deviation_um\n";  // 7

usecases::PositioningReport Analyze(const std::string& text, const std::string& name = "p.txt") {
  return usecases::AnalyzePositioning(ingest::ParsePositioningFile(text, name));
}

InvalidInput Refused(const std::string& text) {
  return Expect<InvalidInput>([&] { Analyze(text); });
}

TEST(PositioningParser, HumidityOutOfRangeNamesFieldAndLine) {
  const std::string text =
      "# format: kinemetric-positioning/1\n# machine_id: m1\n# axis: X\n# cycle: linear\n"
      "# datum_mm: 0\n# air_compensated: no\n# air_temperature_c: 20\n# air_pressure_pa: 101325\n"
      "# air_humidity_pct: 140\n# laser_wavelength_nm: 632.99\nrun,direction,target_mm,"
      "measured_mm\n1,+,0,0\n1,-,0,0\n2,+,0,0\n2,-,0,0\n";
  const InvalidInput e = Refused(text);
  EXPECT_EQ(e.file(), "p.txt");
  EXPECT_EQ(e.line(), 9u);
  EXPECT_EQ(e.field(), "air_humidity_pct");
  EXPECT_TRUE(Contains(e.what(), "p.txt:9")) << e.what();
}

TEST(PositioningParser, OneDirectionOnly) {
  const InvalidInput e =
      Refused(std::string(kHeader) + "1,+,0,1\n1,+,10,1\n1,-,0,1\n2,+,0,1\n2,+,10,1\n2,-,0,1\n");
  EXPECT_EQ(e.line(), 9u);  // target 10 first read there
  EXPECT_EQ(e.field(), "direction");
  EXPECT_TRUE(Contains(e.reason(), "+ direction only")) << e.reason();
}

TEST(PositioningParser, RunsOfUnequalLength) {
  const InvalidInput e = Refused(std::string(kHeader) +
                                 "1,+,0,1\n1,+,10,1\n1,-,10,1\n1,-,0,1\n"
                                 "2,+,0,1\n2,+,10,1\n2,-,10,1\n2,-,0,1\n2,+,20,1\n2,-,20,1\n");
  EXPECT_EQ(e.line(), 12u);
  EXPECT_EQ(e.field(), "run");
  EXPECT_TRUE(Contains(e.reason(), "unequal length")) << e.reason();
}

TEST(PositioningParser, TargetThatDoesNotRepeat) {
  const InvalidInput e = Refused(std::string(kHeader) +
                                 "1,+,0,1\n1,+,10,1\n1,-,10,1\n1,-,0,1\n"
                                 "2,+,0,1\n2,+,15,1\n2,-,15,1\n2,-,0,1\n");
  EXPECT_EQ(e.field(), "target_mm");
  EXPECT_EQ(e.line(), 12u);  // run 2 starts there
  EXPECT_TRUE(Contains(e.reason(), "every run")) << e.reason();
}

TEST(PositioningParser, FieldErrors) {
  EXPECT_EQ(Refused(std::string(kHeader) + "1,up,0,1\n").field(), "direction");
  EXPECT_EQ(Refused(std::string(kHeader) + "1.5,+,0,1\n").field(), "run");
  std::string bad_cycle = kHeader;
  bad_cycle.replace(bad_cycle.find("linear"), 6, "zigzag");
  const InvalidInput e = Refused(bad_cycle + "1,+,0,1\n");
  EXPECT_EQ(e.field(), "cycle");
  EXPECT_EQ(e.line(), 4u);
  std::string no_air = kHeader;
  no_air.replace(no_air.find("yes"), 3, "no");
  EXPECT_EQ(Refused(no_air + "1,+,0,1\n").field(), "air_temperature_c");
  std::string material = kHeader;
  material.insert(material.find("run,"), "# material_temperature_c: 23\n");
  EXPECT_EQ(Refused(material + "1,+,0,1\n").field(), "expansion_ppm_per_k");
}

// A table read back from the LinuxCNC text: nominal mm → (forward, reverse) trim in mm.
std::map<double, std::pair<double, double>> ParseLinuxCnc(const std::string& text) {
  std::map<double, std::pair<double, double>> table;
  std::istringstream in(text);
  double nominal = 0, fwd = 0, rev = 0;
  while (in >> nominal >> fwd >> rev) table[nominal] = {fwd, rev};
  return table;
}

TEST(PositioningCompensation, LinuxCncTableRemovesTheSystematicDeviation) {
  test::Truth t;
  t.targets_mm = {0, 90, 200, 330, 410, 500, 640, 700, 820, 1000};  // uneven
  t.reversal_um = 6.0;
  t.amplitude_um = 5.0;
  const usecases::PositioningReport r = Analyze(test::SimulateFile(t));
  const std::string text = usecases::ExportLinuxCnc(r);
  const auto table = ParseLinuxCnc(text);
  ASSERT_EQ(table.size(), t.targets_mm.size());
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), long(t.targets_mm.size()));
  // The machine with the trims added: each reading moves by the trim of its direction.
  std::vector<Reading> compensated = r.readings;
  for (Reading& x : compensated) {
    const auto& [fwd_mm, rev_mm] = table.at(x.target_mm);
    x.deviation_um += 1000.0 * (x.direction > 0 ? fwd_mm : rev_mm);
  }
  const PositioningFigures after = EvaluatePositioning(compensated);
  EXPECT_GT(r.figures.iso.systematic_deviation_um, 10.0);
  EXPECT_LE(after.iso.systematic_deviation_um, r.figures.iso.repeatability_um);
  EXPECT_LT(after.iso.systematic_deviation_um, 0.01);  // trims to 1 nm
}

TEST(PositioningCompensation, SignsFromFirstPrinciples) {
  // The machine overshoots by +10 µm at 100 mm in both directions, exact elsewhere.
  std::string text = kHeader;
  for (int run = 1; run <= 2; ++run) {
    for (int dir : {1, -1}) {
      for (double p : {0.0, 100.0, 200.0}) {
        text += std::to_string(run) + "," + (dir > 0 ? "+" : "-") + "," + std::to_string(p) + "," +
                (p == 100.0 ? "10" : "0") + "\n";
      }
    }
  }
  const usecases::PositioningReport r = Analyze(text);
  EXPECT_DOUBLE_EQ(r.compensation.forward_um[1], -10.0);
  EXPECT_DOUBLE_EQ(r.compensation.reverse_um[1], -10.0);
  EXPECT_TRUE(Contains(usecases::ExportLinuxCnc(r), "100.000000 -0.010000 -0.010000\n"));
  EXPECT_TRUE(Contains(usecases::ExportSinumerik(r), "$AA_ENC_COMP[0,1,AX1]=0.010000\n"));
  EXPECT_TRUE(
      Contains(usecases::ExportCompensationCsv(r), "100.000000,-10.0000,-10.0000,10.0000\n"));
}

TEST(PositioningCompensation, SinumerikEvenGrid) {
  test::Truth t;
  t.targets_mm = {0, 100, 250, 400};  // uneven: 4 points 133.33 mm apart
  const usecases::PositioningReport r = Analyze(test::SimulateFile(t));
  const std::string s = usecases::ExportSinumerik(r);
  EXPECT_TRUE(Contains(s, "not evenly spaced")) << s;
  EXPECT_TRUE(Contains(s, "$AA_ENC_COMP_STEP[0,AX1]=133.333333\n")) << s;
  EXPECT_TRUE(Contains(s, "$AA_ENC_COMP_MIN[0,AX1]=0.000000\n"));
  EXPECT_TRUE(Contains(s, "$AA_ENC_COMP_MAX[0,AX1]=400.000000\n"));
  EXPECT_TRUE(Contains(s, "$AA_ENC_COMP[0,3,AX1]="));
  EXPECT_FALSE(Contains(s, "$AA_ENC_COMP[0,4,AX1]="));
  EXPECT_EQ(Expect<InvalidInput>([&] { usecases::ExportCompensation(r, "fanuc"); }).field(),
            "--format");
}

// A file whose header carries program lines behind a carriage return (or another character
// that ends a line on a controller) is refused naming the file, the line and the key.
TEST(PositioningControllerText, LineBreaksInHeaderValuesAreRefused) {
  const std::string rows = "1,+,0,0\n1,+,100,1\n1,-,0,0\n1,-,100,1\n";
  for (const char* brk : {"\r", "\v", "\f", "\xC2\x85", "\xE2\x80\xA8"}) {
    std::string text = kHeader;
    const std::string bad = std::string("vmc") + brk + "$AA_ENC_COMP[0,0,AX1]=9.999" + brk + "M30";
    text.replace(text.find("m1"), 2, bad);
    const auto e = Refused(text + rows);
    EXPECT_EQ(e.file(), "p.txt");
    EXPECT_EQ(e.line(), 2u) << e.what();
    EXPECT_EQ(e.field(), "machine_id") << e.what();
  }
  std::string axis = kHeader;
  axis.replace(axis.find("# axis: X"), 9, "# axis: X\rM30");
  const auto e = Refused(axis + rows);
  EXPECT_EQ(e.line(), 3u);
  EXPECT_EQ(e.field(), "axis");
}

TEST(PositioningControllerText, MachineIdsThatCannotNameAMachineAreRefused) {
  const std::string rows = "1,+,0,0\n1,+,100,1\n1,-,0,0\n1,-,100,1\n";
  for (const std::string& bad :
       {std::string("a/b"), std::string("a\\b"), std::string(".."), std::string("a\tb"),
        std::string("x\xE2\x80\xAE"
                    "gpj.exe"),
        std::string(257, 'm')}) {
    std::string text = kHeader;
    text.replace(text.find("m1"), 2, bad);
    const auto e = Refused(text + rows);
    EXPECT_EQ(e.line(), 2u) << e.what();
    EXPECT_EQ(e.field(), "machine_id") << e.what();
  }
}

// Text from a stored measurement reaches a controller program only when it is of the safe
// alphabet: an id stored before ids were checked is left out, never copied.
TEST(PositioningControllerText, ExportsCarryOnlySafeNames) {
  std::string text = kHeader;
  for (int run = 1; run <= 2; ++run) {
    for (const char* dir : {"+", "-"}) {
      for (const char* p : {"0", "100", "200"})
        text += std::to_string(run) + "," + dir + "," + p + ",1\n";
    }
  }
  usecases::PositioningReport r = Analyze(text);
  EXPECT_TRUE(Contains(usecases::ExportSinumerik(r), "machine m1, axis X"));
  r.machine_id = "vmc\r$AA_ENC_COMP[0,0,AX1]=9.999\rM30";
  r.axis = "X\x0BM30";
  for (const char* format : {"sinumerik", "linuxcnc", "csv"}) {
    const std::string out = usecases::ExportCompensation(r, format);
    EXPECT_FALSE(Contains(out, "M30")) << format << ":\n" << out;
    EXPECT_FALSE(Contains(out, "9.999")) << format;
    for (const char c : out) {
      const auto u = static_cast<unsigned char>(c);
      EXPECT_TRUE(c == '\n' || (u >= 0x20 && u < 0x7F)) << format << " holds byte " << int(u);
    }
  }
  EXPECT_TRUE(Contains(usecases::ExportSinumerik(r), "machine (name left out"));
}

}  // namespace
}  // namespace km::positioning
