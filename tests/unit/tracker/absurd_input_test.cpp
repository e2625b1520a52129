// Absurd laser-tracker inputs are refused with a clear error: tracker position guesses far
// outside any machine (they made the initial fit fail and the solver read an empty result),
// and point ids beyond the range of an int (they turned negative).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "analysis/core/errors.h"
#include "analysis/tracker/selfcal_problem.h"
#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_sim.h"
#include "ingest/tracker_parser.h"
#include "tests/unit/tracker/tracker_test_util.h"

namespace km {
namespace {

tracker::TrackerReadings Survey() {
  const auto o = tracker::test::MakeSetup(400.0, 4, 4, 11);
  return tracker::SimulateTrackerSurvey(o).readings;
}

// The survey written as a file with `header` added after the `mode` line.
std::string SurveyFile(const std::string& header) {
  std::string text = ingest::WriteTrackerFile(Survey());
  const auto at =
      text.find("# mode: simultaneous\n") + std::string("# mode: simultaneous\n").size();
  return text.insert(at, header);
}

void ExpectBadGuess(const std::string& header, const std::string& words) {
  SCOPED_TRACE(header);
  try {
    const auto f = ingest::ParseTrackerFile(SurveyFile(header), "survey.txt");
    tracker::SelfCalibrate(f.readings);
    ADD_FAILURE() << "accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), "survey.txt");
    EXPECT_EQ(e.line(), 5u) << e.what();
    EXPECT_EQ(e.field(), "tracker_guess_mm") << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(TrackerGuess, AbsurdGuessesAreRefusedNamingTheLine) {
  ExpectBadGuess("# tracker_guess_mm: 1, 1e300, 1e300, 1e300\n", "100 m");
  ExpectBadGuess("# tracker_guess_mm: 1, 1e300, 0, 0\n", "100 m");
  ExpectBadGuess("# tracker_guess_mm: 2, 0, -100001, 0\n", "100 m");
  ExpectBadGuess("# tracker_guess_mm: 4, 0, 0, 1e150\n", "100 m");
}

TEST(TrackerGuess, SaneGuessesStillSolve) {
  const auto o = tracker::test::MakeSetup(400.0, 4, 4, 11);
  const std::string g = "# tracker_guess_mm: 1, " + std::to_string(o.trackers_mm[0].x()) + ", " +
                        std::to_string(o.trackers_mm[0].y()) + ", " +
                        std::to_string(o.trackers_mm[0].z()) + "\n";
  const auto f = ingest::ParseTrackerFile(SurveyFile(g), "survey.txt");
  ASSERT_EQ(f.readings.guesses.size(), 1u);
  const auto r = tracker::SelfCalibrate(f.readings);
  EXPECT_LT(r.residual_rms_um, 1.0);
  // A guess far away but within 100 m is a guess, not an error: it solves or says why not.
  const auto far = ingest::ParseTrackerFile(
      SurveyFile("# tracker_guess_mm: 2, 99000, -99000, 99000\n"), "survey.txt");
  try {
    tracker::SelfCalibrate(far.readings);
  } catch (const DidNotConverge&) {
  } catch (const NotObservable&) {
  }
}

TEST(TrackerGuess, TheAnalysisRefusesAbsurdGuessesItself) {
  auto r = Survey();
  for (const double v : {1e300, -2e5, std::numeric_limits<double>::infinity(),
                         std::numeric_limits<double>::quiet_NaN()}) {
    SCOPED_TRACE(v);
    r.guesses = {{2, Eigen::Vector3d(0.0, v, 0.0)}};
    try {
      tracker::SelfCalibrate(r);
      ADD_FAILURE() << "accepted";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), "tracker_guess_mm") << e.what();
      EXPECT_NE(std::string(e.what()).find("tracker 3"), std::string::npos) << e.what();
    }
  }
}

TEST(TrackerGuess, AFailedInitialFitIsReportedNotRead) {
  const auto r = Survey();
  const auto problem = tracker::SelfCalProblem::FromReadings(r);
  const Eigen::Vector3d absurd = Eigen::Vector3d::Constant(1e300);
  EXPECT_THROW(tracker::InitialiseTracker(problem, r, 0, &absurd), DidNotConverge);
  const Eigen::Vector3d nan = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  EXPECT_THROW(tracker::InitialiseTracker(problem, r, 1, &nan), DidNotConverge);
}

TEST(TrackerPointIds, IdsBeyondAnIntAreRefused) {
  const std::string text = ingest::WriteTrackerFile(Survey());
  const auto row = text.find("\n1,", text.find("point,x_mm")) + 1;
  const auto line =
      static_cast<std::size_t>(std::count(text.begin(), text.begin() + row, '\n')) + 1;
  for (const char* id : {"3000000000", "2147483648", "-2147483649", "1000000000000000"}) {
    SCOPED_TRACE(id);
    const std::string bad = text.substr(0, row) + id + text.substr(row + 1);
    try {
      ingest::ParseTrackerFile(bad, "ids.txt");
      ADD_FAILURE() << "accepted";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.file(), "ids.txt");
      EXPECT_EQ(e.line(), line) << e.what();
      EXPECT_EQ(e.field(), "point") << e.what();
    }
  }
  // The largest int is a valid id, and it stays what it was.
  const std::string big = text.substr(0, row) + "2147483647" + text.substr(row + 1);
  const auto f = ingest::ParseTrackerFile(big, "ids.txt");
  EXPECT_EQ(f.readings.point_ids[0], 2147483647);
  const std::string neg = text.substr(0, row) + "-2147483648" + text.substr(row + 1);
  EXPECT_EQ(ingest::ParseTrackerFile(neg, "ids.txt").readings.point_ids[0], -2147483648LL);
}

}  // namespace
}  // namespace km
