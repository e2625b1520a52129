// kinemetric-tracker/1 parser: round trip through the writer, a self-calibration from the
// parsed file, and bad inputs refused with file / line / field.
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_sim.h"
#include "ingest/tracker_parser.h"
#include "tests/unit/tracker/tracker_test_util.h"

namespace km::ingest {
namespace {

const char* kGood =
    "# format: kinemetric-tracker/1\n"
    "# machine_id: vmc-1\n"
    "# trackers: 4\n"
    "# mode: simultaneous\n"
    "# tracker_guess_mm: 1, -500, 300, -200\n"
    "# tracker_guess_mm: 3, 800, 900, 100\n"
    "# operator: someone\n"
    "point,x_mm,y_mm,z_mm,d1_um,d2_um,d3_um,d4_um\n"
    "1,0,0,0,0,0,0,0\n"
    "2,100,0,0,1.5,-2.25,3,4\n"
    "# beam_break: 2, 3\n"
    "3,100,100,0,5,6,7,8\n";

TEST(TrackerParser, ReadsTheContractFormat) {
  const TrackerFile f = ParseTrackerFile(kGood, "good.csv");
  const auto& r = f.readings;
  EXPECT_EQ(r.machine_id, "vmc-1");
  EXPECT_EQ(r.mode, tracker::TrackerMode::kSimultaneous);
  ASSERT_EQ(r.NumPoints(), 3);
  ASSERT_EQ(r.NumTrackers(), 4);
  EXPECT_EQ(r.point_ids[2], 3);
  EXPECT_DOUBLE_EQ(r.commanded_mm[1].x(), 100.0);
  EXPECT_DOUBLE_EQ(r.displacement_um(1, 1), -2.25);
  ASSERT_EQ(r.guesses.size(), 2u);
  EXPECT_EQ(r.guesses[1].tracker, 2);
  EXPECT_DOUBLE_EQ(r.guesses[1].position_mm.y(), 900.0);
  ASSERT_EQ(r.beam_breaks.size(), 1u);
  EXPECT_EQ(r.beam_breaks[0].tracker, 1);
  EXPECT_EQ(r.beam_breaks[0].row, 2u);
  EXPECT_EQ(f.metadata.at("operator"), "someone");
}

TEST(TrackerParser, RoundTripAndSolve) {
  auto o = tracker::test::MakeSetup(400.0, 5, 4, 3);
  o.mode = tracker::TrackerMode::kSequential;
  o.beam_breaks = {{2, 60}};
  auto sim = tracker::SimulateTrackerSurvey(o);
  sim.readings.guesses.push_back({0, o.trackers_mm[0]});
  const std::string text = WriteTrackerFile(sim.readings);
  const TrackerFile f = ParseTrackerFile(text, "sim.csv");
  EXPECT_EQ(f.readings.mode, tracker::TrackerMode::kSequential);
  ASSERT_EQ(f.readings.beam_breaks.size(), 1u);
  EXPECT_EQ(f.readings.beam_breaks[0].row, 60u);
  EXPECT_EQ(f.readings.guesses.size(), 1u);
  EXPECT_LT((f.readings.displacement_um - sim.readings.displacement_um).cwiseAbs().maxCoeff(),
            0.5e-4);
  const auto a = tracker::SelfCalibrate(sim.readings);
  const auto b = tracker::SelfCalibrate(f.readings);
  for (std::size_t i = 0; i < a.volumetric_error_um.size(); ++i) {
    EXPECT_LT((a.volumetric_error_um[i] - b.volumetric_error_um[i]).norm(), 0.01);
  }
}

// The error must name the file, the line (when given) and the field.
void ExpectBad(const std::string& text, std::size_t line, const std::string& field,
               const std::string& words) {
  try {
    ParseTrackerFile(text, "bad.csv");
    ADD_FAILURE() << "accepted: " << text;
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "bad.csv");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  const auto p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  return s.replace(p, from.size(), to);
}

TEST(TrackerParser, RefusesBadInput) {
  const std::string g = kGood;
  ExpectBad(Replace(g, "kinemetric-tracker/1", "kinemetric-dbb/1"), 1, "format", "expected");
  ExpectBad(Replace(g, "# machine_id: vmc-1\n", ""), 0, "machine_id", "missing");
  ExpectBad(Replace(g, "# trackers: 4", "# trackers: 3"), 3, "trackers", "≥ 4");
  ExpectBad(Replace(g, "# trackers: 4", "# trackers: 4.5"), 3, "trackers", "integer");
  ExpectBad(Replace(g, "# trackers: 4", "# trackers: four"), 3, "trackers", "not a finite");
  ExpectBad(Replace(g, "# mode: simultaneous", "# mode: parallel"), 4, "mode", "parallel");
  ExpectBad(Replace(g, "1, -500, 300, -200", "5, -500, 300, -200"), 5, "tracker_guess_mm", "1..4");
  ExpectBad(Replace(g, "1, -500, 300, -200", "1, -500, 300"), 5, "tracker_guess_mm", "j, x, y, z");
  ExpectBad(Replace(g, "3, 800, 900, 100", "1, 800, 900, 100"), 6, "tracker_guess_mm", "twice");
  ExpectBad(
      "# format: kinemetric-tracker/1\n# machine_id: m\n# trackers: 4\n# mode: sequential\n"
      "point,x_mm,y_mm,z_mm,d1_um,d2_um,d3_um\n1,0,0,0,0,0,0\n",
      5, "d4_um", "missing");
  ExpectBad(Replace(g, "y_mm,", "yy_mm,"), 8, "y_mm", "missing");
  ExpectBad(
      Replace(Replace(Replace(Replace(g, "d4_um\n", "d4_um,d5_um\n"), "0,0,0,0\n", "0,0,0,0,0\n"),
                      "3,4\n", "3,4,5\n"),
              "7,8\n", "7,8,9\n"),
      8, "d5_um", "'trackers' is 4");
  ExpectBad(Replace(g, "2,100,0,0,1.5", "2.5,100,0,0,1.5"), 10, "point", "integer");
  ExpectBad(Replace(g, "3,100,100,0", "2,100,100,0"), 12, "point", "repeated");
  ExpectBad(Replace(g, "1.5,-2.25", "1.5,abc"), 10, "d2_um", "not a finite");
  ExpectBad(Replace(g, "1.5,-2.25,3,4", "1.5,-2.25,3"), 10, "", "expected 8 values");
  ExpectBad(Replace(g, "# beam_break: 2, 3", "# beam_break: 7, 3"), 11, "beam_break", "1..4");
  ExpectBad(Replace(g, "# beam_break: 2, 3", "# beam_break: 2, 9"), 11, "beam_break",
            "not in the data");
  ExpectBad(Replace(g, "# beam_break: 2, 3", "# beam_break: 2, 1"), 11, "beam_break",
            "first point");
  ExpectBad(Replace(g, "# beam_break: 2, 3", "# beam_break: 2"), 11, "beam_break", "two");
  ExpectBad(Replace(g, "# beam_break: 2, 3", "# beam_break: 2, 3, somewhere"), 11, "beam_break",
            "'elsewhere'");
  ExpectBad(Replace(g, "# beam_break: 2, 3", "# beam_break: 2, 3, 4"), 11, "beam_break",
            "'at_point'");
  ExpectBad(Replace(g, "# beam_break: 2, 3", "# beam_break: 2, x, elsewhere"), 11, "beam_break",
            "two integers");
  ExpectBad(Replace(g, "# beam_break: 2, 3", "# note: hello"), 11, "note", "unexpected");
  ExpectBad(
      Replace(g,
              "1,0,0,0,0,0,0,0\n2,100,0,0,1.5,-2.25,3,4\n# beam_break: 2, 3\n3,100,100,0,5,6,7,8\n",
              ""),
      8, "", "no data rows");
  ExpectBad(Replace(g, "# trackers: 4\n", "# trackers: 4\n# trackers: 5\n"), 4, "trackers",
            "duplicated");
}

TEST(TrackerParser, WhereABeamBreakWasReZeroed) {
  // Two fields: re-zeroed at the point named (what a beam_break line always said: a new zero
  // from that point on); 'at_point' says the same; 'elsewhere': not at a surveyed point.
  for (const auto& [line, elsewhere] :
       std::vector<std::pair<std::string, bool>>{{"# beam_break: 2, 3", false},
                                                 {"# beam_break: 2, 3, at_point", false},
                                                 {"# beam_break: 2,3 ,  elsewhere ", true}}) {
    SCOPED_TRACE(line);
    const auto r = ParseTrackerFile(Replace(kGood, "# beam_break: 2, 3", line), "b.csv").readings;
    ASSERT_EQ(r.beam_breaks.size(), 1u);
    EXPECT_EQ(r.beam_breaks[0].tracker, 1);
    EXPECT_EQ(r.beam_breaks[0].row, 2u);
    EXPECT_EQ(r.beam_breaks[0].elsewhere, elsewhere);
    // Written back as read.
    const auto again = ParseTrackerFile(WriteTrackerFile(r), "again.csv").readings;
    ASSERT_EQ(again.beam_breaks.size(), 1u);
    EXPECT_EQ(again.beam_breaks[0].elsewhere, elsewhere);
  }
}

}  // namespace
}  // namespace km::ingest
