// `kinemetric rotary analyze`, `discover` and `export` end to end through the command registry
// (cli/cmd_rotary.cpp is compiled into this test): a simulated file gives exit status 0 and the
// documented JSON (docs/formats.md §3.18); a bad file is bad input (exit status 2 in main) naming
// file, line and field.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "tests/unit/cli_test_fixture.h"
#include "tests/unit/rotary/rotary_sim.h"

namespace km::cli {
namespace {

class RotaryCli : public test::CliTest {};

TEST_F(RotaryCli, AnalysesASimulatedFile) {
  const auto f = rotary::test::Simulate("AC", "full", 21);
  std::ostringstream out;
  ASSERT_EQ(Registry().at("rotary analyze").run(JsonArgs({f.path}), out), 0);
  const auto j = nlohmann::json::parse(out.str());
  EXPECT_EQ(j["analysis_version"], "rotary/1");
  EXPECT_EQ(j["kinematics"], "AC-trunnion");
  EXPECT_EQ(j["rank"], 8);
  EXPECT_EQ(j["parameters"], 8);
  EXPECT_EQ(j["poses"], 60);
  EXPECT_EQ(j["residuals"].size(), 60u);
  for (const char* key :
       {"YOA_um", "ZOA_um", "BOA_urad", "COA_urad", "XOC_um", "YOC_um", "AOC_urad", "BOC_urad"}) {
    ASSERT_TRUE(j["location_errors"].contains(key)) << key;
    EXPECT_TRUE(j["location_errors"][key]["value"].is_number()) << key;
    EXPECT_TRUE(j["location_errors"][key]["sigma"].is_number()) << key;
  }
  EXPECT_GT(j["measured_rms_um"].get<double>(), 5.0);
  EXPECT_LT(j["residual_rms_um"].get<double>(), 0.7);
  EXPECT_TRUE(j["not_identifiable"].empty());

  std::ostringstream text;
  Args plain;
  plain.positional = {f.path};
  ASSERT_EQ(Registry().at("rotary analyze").run(plain, text), 0);
  EXPECT_NE(text.str().find("YOA"), std::string::npos);
  EXPECT_NE(text.str().find("rank 8 of 8"), std::string::npos);
  EXPECT_NE(text.str().find("RMS before"), std::string::npos);
}

TEST_F(RotaryCli, NamesWhatThePosesCannotDetermine) {
  const auto f = rotary::test::Simulate("AC", "tilt0", 22);
  std::ostringstream out;
  Args plain;
  plain.positional = {f.path};
  ASSERT_EQ(Registry().at("rotary analyze").run(plain, out), 0);
  EXPECT_NE(out.str().find("YOA   not identifiable"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("rank 4 of 8"), std::string::npos) << out.str();
}

TEST_F(RotaryCli, BadFileIsBadInputNamingLineAndField) {
  const auto f = rotary::test::Simulate("AC", "full", 23);
  std::ifstream in(f.path);
  std::stringstream text;
  text << in.rdbuf();
  std::string bad = text.str();
  bad.replace(bad.find("a_deg,c_deg"), 11, "b_deg,c_deg");  // a BC column in an AC file
  const std::string path = Write("bad.txt", bad);
  std::ostringstream out;
  try {
    Registry().at("rotary analyze").run(JsonArgs({path}), out);
    FAIL() << "accepted: " << out.str();
  } catch (const InvalidInput& e) {  // main maps it to exit status 2
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.line(), 11u);
    EXPECT_EQ(e.field(), "b_deg");
  }
}

TEST_F(RotaryCli, DiscoverNamesAHiddenCAngleError) {
  const auto f = rotary::test::Simulate("AC", "full", 25, 1000, "--hidden c_angle --dt 60");
  std::ostringstream out;
  ASSERT_EQ(Registry().at("rotary discover").run(JsonArgs({f.path}), out), 0);
  const auto j = nlohmann::json::parse(out.str());
  EXPECT_EQ(j["analysis_version"], "rotary-discover/1");
  ASSERT_EQ(j["named"].size(), 1u);
  EXPECT_EQ(j["named"][0]["effect"], "c_angular_positioning");
  EXPECT_EQ(j["verdict"], "complete");
  Args text;
  text.positional = {f.path};
  std::ostringstream plain;
  ASSERT_EQ(Registry().at("rotary discover").run(text, plain), 0);
  EXPECT_NE(plain.str().find("angular positioning error of C named"), std::string::npos);
}

TEST_F(RotaryCli, ExportPrintsHalLinesAndACsvTable) {
  const auto f = rotary::test::Simulate("BC", "full", 26);
  Args args;
  args.positional = {f.path};
  std::ostringstream hal;
  ASSERT_EQ(Registry().at("rotary export").run(args, hal), 0);
  EXPECT_NE(hal.str().find("setp xyzbc-trt-kins.x-offset "), std::string::npos);
  args.options["--format"] = "csv";
  std::ostringstream csv;
  ASSERT_EQ(Registry().at("rotary export").run(args, csv), 0);
  EXPECT_EQ(csv.str().rfind("parameter,nominal_mm,delta_mm,corrected_mm\n", 0), 0u);
  EXPECT_NE(csv.str().find("AOB,"), std::string::npos);
  args.options["--format"] = "fanuc";
  std::ostringstream bad;
  EXPECT_THROW(Registry().at("rotary export").run(args, bad), InvalidInput);
}

}  // namespace
}  // namespace km::cli
