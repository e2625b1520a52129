// `kinemetric tracker selfcal` run through the command registry (the command file is compiled
// into this test): an absurd tracker guess is bad input (exit status 2 in main), not a crash.
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "ingest/tracker_parser.h"
#include "tests/unit/cli_test_fixture.h"
#include "tests/unit/tracker/tracker_test_util.h"

namespace km::cli {
namespace {

class TrackerCli : public test::CliTest {
 protected:
  std::string SurveyFile(const std::string& header) {
    const auto o = tracker::test::MakeSetup(400.0, 4, 4, 13);
    std::string text = ingest::WriteTrackerFile(tracker::SimulateTrackerSurvey(o).readings);
    const std::string mode = "# mode: simultaneous\n";
    text.insert(text.find(mode) + mode.size(), header);
    return Write("survey.txt", text);
  }
};

TEST_F(TrackerCli, AbsurdGuessIsBadInputNamingTheLine) {
  const std::string path = SurveyFile("# tracker_guess_mm: 1, 1e300, 1e300, 1e300\n");
  std::ostringstream out;
  try {
    Registry().at("tracker selfcal").run(JsonArgs({path}), out);
    FAIL() << "accepted: " << out.str();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.line(), 5u);
    EXPECT_EQ(e.field(), "tracker_guess_mm");
  }
}

TEST_F(TrackerCli, SpatialOutliersAreWarningsInTheJson) {
  // Two gross errors on point 31 that cancel in its single redundant reading: no reading can be
  // rejected; the point is named in spatial_outliers and in warnings, and kept.
  const auto o = tracker::test::MakeSetup(400.0, 5, 4, 17);
  auto sim = tracker::SimulateTrackerSurvey(o);
  tracker::test::AddCancellingGrossErrors(sim, o.trackers_mm, 30, 40.0);
  const std::string path = Write("survey.txt", ingest::WriteTrackerFile(sim.readings));
  std::ostringstream out;
  ASSERT_EQ(Registry().at("tracker selfcal").run(JsonArgs({path}), out), 0);
  const auto j = nlohmann::json::parse(out.str());
  EXPECT_TRUE(j["rejected_readings"].empty());
  ASSERT_EQ(j["spatial_outliers"].size(), 1u);
  const auto& x = j["spatial_outliers"][0];
  EXPECT_EQ(x["point"], 31);
  EXPECT_EQ(x["index"], 30);
  EXPECT_EQ(x["departure_um"].size(), 3u);
  EXPECT_GT(x["departure_sigmas"].get<double>(), 6.0);
  EXPECT_NE(x["reason"].get<std::string>().find("kept"), std::string::npos);
  EXPECT_FALSE(j["volumetric_error_um"][30].is_null());
  ASSERT_EQ(j["warnings"].size(), 1u);
  EXPECT_NE(j["warnings"][0].get<std::string>().find("point 31 departs"), std::string::npos);
}

TEST_F(TrackerCli, ASurveyWithoutGuessesSolves) {
  std::ostringstream out;
  EXPECT_EQ(Registry().at("tracker selfcal").run(JsonArgs({SurveyFile("")}), out), 0);
  EXPECT_NE(out.str().find("volumetric_error_um"), std::string::npos);
}

}  // namespace
}  // namespace km::cli
