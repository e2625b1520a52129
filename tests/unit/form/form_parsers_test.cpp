// Parsers of kinemetric-straightness/1, kinemetric-flatness/1, kinemetric-parallelism/1:
// good files round-trip, every kind of bad input is an InvalidInput naming line and field.
#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"
#include "ingest/form_parsers.h"

namespace km::ingest {
namespace {

const std::string kStraight =
    "# format: kinemetric-straightness/1\n"  // line 1
    "# machine_id: m1\n"                     // 2
    "# axis: x\n"                            // 3
    "# error_direction: Z\n"                 // 4
    "# sensor: capacitance\n"                // 5
    "# reference: optical_flat\n"            // 6
    "# reversal: a\n"                        // 7
    "# pair_id: p1\n"                        // 8
    "# operator: ks\n"                       // 9
    "position_mm,deviation_um\n"             // 10
    "0,0.10\n"                               // 11
    "\n"                                     // 12
    "10.5,0.25\n"                            // 13
    "21,-0.05\n";                            // 14

// Replaces the first occurrence of `from` in the good file.
std::string Edit(const std::string& base, const std::string& from, const std::string& to) {
  std::string s = base;
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  s.replace(at, from.size(), to);
  return s;
}

// Runs `f`, expects InvalidInput naming `line` and `field`.
template <typename F>
void ExpectInvalid(F f, std::size_t line, const std::string& field) {
  try {
    f();
    ADD_FAILURE() << "no InvalidInput (expected line " << line << ", field " << field << ")";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "s.txt") << e.what();
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.field(), field) << e.what();
  }
}

void ExpectBadStraightness(const std::string& text, std::size_t line, const std::string& field) {
  ExpectInvalid([&] { ParseStraightnessFile(text, "s.txt"); }, line, field);
}

TEST(StraightnessParser, ReadsAGoodFile) {
  const StraightnessFile f = ParseStraightnessFile(kStraight, "s.txt");
  EXPECT_EQ(f.machine_id, "m1");
  EXPECT_EQ(f.axis, "X");
  EXPECT_EQ(f.error_direction, "Z");
  EXPECT_EQ(f.sensor, "capacitance");
  EXPECT_EQ(f.reference, "optical_flat");
  EXPECT_EQ(f.reversal, "a");
  EXPECT_EQ(f.pair_id, "p1");
  EXPECT_EQ(f.reversal_line, 7u);
  EXPECT_EQ(f.metadata.at("operator"), "ks");
  ASSERT_EQ(f.profile.position_mm.size(), 3u);
  EXPECT_DOUBLE_EQ(f.profile.position_mm[1], 10.5);
  EXPECT_DOUBLE_EQ(f.profile.deviation_um[2], -0.05);
  EXPECT_EQ(f.row_lines[1], 13u);
}

TEST(StraightnessParser, RejectsBadInputNamingLineAndField) {
  ExpectBadStraightness(Edit(kStraight, "# machine_id: m1\n", ""), 0, "machine_id");
  ExpectBadStraightness(Edit(kStraight, "# axis: x\n", "# axis: x\n# axis: y\n"), 4, "axis");
  ExpectBadStraightness(Edit(kStraight, "10.5,0.25", "10.5,0.2x5"), 13, "deviation_um");
  ExpectBadStraightness(Edit(kStraight, "10.5,0.25", "nan,0.25"), 13, "position_mm");
  ExpectBadStraightness(Edit(kStraight, "21,-0.05", "10.5,-0.05"), 14, "position_mm");
  ExpectBadStraightness(Edit(kStraight, "21,-0.05", "3,-0.05"), 14, "position_mm");
  ExpectBadStraightness(Edit(kStraight, "21,-0.05\n", ""), 13, "position_mm");  // 2 points
  ExpectBadStraightness(Edit(kStraight, "straightness/1", "straightness/2"), 1, "format");
  ExpectBadStraightness(Edit(kStraight, "kinemetric-straightness/1", "kinemetric-flatness/1"), 1,
                        "format");
  ExpectBadStraightness(Edit(kStraight, "# sensor: capacitance", "# sensor: feeler"), 5, "sensor");
  ExpectBadStraightness(Edit(kStraight, "# error_direction: Z", "# error_direction: X"), 4,
                        "error_direction");
  ExpectBadStraightness(Edit(kStraight, "# axis: x", "# axis: q"), 3, "axis");
  ExpectBadStraightness(Edit(kStraight, "# pair_id: p1\n", ""), 7, "pair_id");
  ExpectBadStraightness(Edit(kStraight, "# reversal: a\n", ""), 7, "reversal");
  ExpectBadStraightness(Edit(kStraight, "# reversal: a", "# reversal: c"), 7, "reversal");
  ExpectBadStraightness(Edit(kStraight, "# reference: optical_flat", "# reference:"), 6,
                        "reference");
  ExpectBadStraightness(Edit(kStraight, "position_mm,deviation_um", "position_mm,dev_um"), 10,
                        "deviation_um");
  ExpectBadStraightness(Edit(kStraight, "\n10.5", "# note: x\n10.5"), 12, "note");
  ExpectBadStraightness(Edit(kStraight, "10.5,0.25", "10.5"), 13, "");
}

TEST(StraightnessParser, ReversalSetUp) {
  // Absent: the artefact was turned over and the sensor stayed (the default).
  const StraightnessFile d = ParseStraightnessFile(kStraight, "s.txt");
  EXPECT_EQ(d.reversal_setup, "artefact");
  EXPECT_EQ(d.reversal_setup_line, 0u);
  for (const char* value : {"artefact", "artefact_and_sensor", "Artefact_And_Sensor"}) {
    const StraightnessFile f =
        ParseStraightnessFile(Edit(kStraight, "# pair_id: p1\n",
                                   "# pair_id: p1\n# reversal_setup: " + std::string(value) + "\n"),
                              "s.txt");
    EXPECT_EQ(f.reversal_setup,
              std::string(value) == "artefact" ? "artefact" : "artefact_and_sensor");
    EXPECT_EQ(f.reversal_setup_line, 9u);
  }
  // Not part of a pair: no set-up.
  const StraightnessFile single =
      ParseStraightnessFile(Edit(kStraight, "# reversal: a\n# pair_id: p1\n", ""), "s.txt");
  EXPECT_EQ(single.reversal_setup, "");
  // Bad values and a set-up without a pair.
  ExpectBadStraightness(
      Edit(kStraight, "# pair_id: p1\n", "# pair_id: p1\n# reversal_setup: sensor\n"), 9,
      "reversal_setup");
  ExpectBadStraightness(Edit(kStraight, "# pair_id: p1\n", "# pair_id: p1\n# reversal_setup:\n"), 9,
                        "reversal_setup");
  ExpectBadStraightness(
      Edit(kStraight, "# reversal: a\n# pair_id: p1\n", "# reversal_setup: artefact\n"), 7,
      "reversal");
  try {
    ParseStraightnessFile(
        Edit(kStraight, "# pair_id: p1\n", "# pair_id: p1\n# reversal_setup: artifact\n"), "s.txt");
    ADD_FAILURE() << "no InvalidInput";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("artefact_and_sensor"), std::string::npos) << e.what();
  }
}

const std::string kFlat =
    "# format: kinemetric-flatness/1\n"
    "# machine_id: pm600\n"
    "# datum: table\n"
    "x_mm,y_mm,z_um\n"  // 4
    "-260,-260,12\n"    // 5
    "260,-260,3\n"      // 6
    "-260,260,-4\n"     // 7
    "260,260,0\n";      // 8

TEST(FlatnessParser, ReadsAGoodFileAndRejectsBadOnes) {
  const FlatnessFile f = ParseFlatnessFile(kFlat, "s.txt");
  EXPECT_EQ(f.machine_id, "pm600");
  EXPECT_EQ(f.datum, "table");
  ASSERT_EQ(f.grid.z_um.size(), 4u);
  EXPECT_DOUBLE_EQ(f.grid.z_um[2], -4.0);
  const auto bad = [](const std::string& t, std::size_t line, const std::string& field) {
    ExpectInvalid([&] { ParseFlatnessFile(t, "s.txt"); }, line, field);
  };
  // datum is optional.
  EXPECT_NO_THROW(ParseFlatnessFile(Edit(kFlat, "# datum: table\n", ""), "s.txt"));
  bad(Edit(kFlat, "# machine_id: pm600\n", ""), 0, "machine_id");
  bad(Edit(kFlat, "260,260,0", "260,260,zero"), 8, "z_um");
  bad(Edit(kFlat, "260,260,0", "-260,-260,0"), 8, "x_mm");  // repeated grid point
  bad(Edit(kFlat, "x_mm,y_mm,z_um", "x_mm,y,z_um"), 4, "y_mm");
  bad(Edit(kFlat, "-260,260,-4\n260,260,0\n", ""), 6, "z_um");  // 2 points
  // All points on one line.
  bad("# format: kinemetric-flatness/1\n# machine_id: m\nx_mm,y_mm,z_um\n0,0,1\n1,1,2\n2,2,0\n", 3,
      "y_mm");
  bad(Edit(kFlat, "# datum: table", "# datum: table\n# datum: slot"), 4, "datum");
}

const std::string kPar =
    "# format: kinemetric-parallelism/1\n"
    "# machine_id: pm600\n"
    "# axis: X\n"
    "# datum: t_slot\n"
    "position_mm,deviation_um\n"  // 5
    "-190,2\n"                    // 6
    "0,11\n"                      // 7
    "190,21\n";                   // 8

TEST(ParallelismParser, ReadsAGoodFileAndRejectsBadOnes) {
  const ParallelismFile f = ParseParallelismFile(kPar, "s.txt");
  EXPECT_EQ(f.axis, "X");
  EXPECT_EQ(f.datum, "t_slot");
  ASSERT_EQ(f.profile.deviation_um.size(), 3u);
  const auto bad = [](const std::string& t, std::size_t line, const std::string& field) {
    ExpectInvalid([&] { ParseParallelismFile(t, "s.txt"); }, line, field);
  };
  bad(Edit(kPar, "# datum: t_slot\n", ""), 0, "datum");
  bad(Edit(kPar, "# axis: X\n", ""), 0, "axis");
  bad(Edit(kPar, "190,21", "-190,21"), 8, "position_mm");
  bad(Edit(kPar, "0,11", "0,1e999"), 7, "deviation_um");
  bad(Edit(kPar, "0,11\n190,21\n", ""), 6, "position_mm");  // 1 point
  bad(Edit(kPar, "parallelism/1", "straightness/1"), 1, "format");
}

}  // namespace
}  // namespace km::ingest
