// `kinemetric dbb analyze` and `kinemetric report` read a dbb-csv file like the kinemetric-dbb/1
// file of the same test (cli/cmd_dbb.cpp, cli/cmd_report.cpp compiled in directly).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "tests/unit/cli_test_fixture.h"

namespace km::cli {
namespace {

using test::CliTest;

std::string Source(const std::string& relative) {
  return (std::filesystem::path(KINEMETRIC_SOURCE_DIR) / relative).string();
}

std::string RunCommand(const std::string& command, Args args) {
  std::ostringstream out;
  EXPECT_EQ(Registry().at(command).run(args, out), 0);
  return out.str();
}

class DbbCsvCli : public CliTest {};

TEST_F(DbbCsvCli, DbbAnalyzePrintsTheSameFiguresAsForTheKinemetricFile) {
  // The same name in two folders: whatever the output shows of the file is the same too.
  std::filesystem::create_directories(dir_ / "txt");
  std::filesystem::create_directories(dir_ / "csv");
  const auto txt = (dir_ / "txt" / "ccw").string();
  const auto csv = (dir_ / "csv" / "ccw").string();
  std::filesystem::copy_file(Source("data/examples/dbb_xy-r150_ccw.txt"), txt);
  std::filesystem::copy_file(Source("tests/fixtures/dbb-csv/dbb_xy-r150_ccw.csv"), csv);
  Args text_txt, text_csv;
  text_txt.positional = {txt};
  text_csv.positional = {csv};
  const std::string a = RunCommand("dbb analyze", text_txt),
                    b = RunCommand("dbb analyze", text_csv);
  EXPECT_FALSE(a.empty());
  EXPECT_EQ(b, a);
  EXPECT_EQ(RunCommand("dbb analyze", JsonArgs({csv})), RunCommand("dbb analyze", JsonArgs({txt})));
  // With the kinemetric cw partner: one pair, whichever format each file is in.
  const auto cw = Source("data/examples/dbb_xy-r150_cw.txt");
  EXPECT_EQ(RunCommand("dbb analyze", JsonArgs({csv, cw})),
            RunCommand("dbb analyze", JsonArgs({txt, cw})));
}

TEST_F(DbbCsvCli, ReportWritesTheDbbReportOfACsvFile) {
  Args args;
  args.positional = {Source("tests/fixtures/dbb-csv/dbb_xy-r150_ccw.csv"),
                     Source("data/examples/dbb_xy-r150_cw.txt")};
  const auto pdf = (dir_ / "report.pdf").string();
  args.options["--out"] = pdf;
  const std::string out = RunCommand("report", args);
  EXPECT_NE(out.find("wrote " + pdf), std::string::npos) << out;
  EXPECT_GT(std::filesystem::file_size(pdf), 1000u);
}

TEST_F(DbbCsvCli, AnUnrecognisedFileIsRefusedNamingTheFormats) {
  const auto path = Write("x.csv", "angle_deg,dr_um\n0,1\n");
  Args args;
  args.positional = {path};
  try {
    std::ostringstream out;
    Registry().at("dbb analyze").run(args, out);
    FAIL() << "accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.field(), "format");
    EXPECT_NE(e.reason().find("dbb-csv"), std::string::npos) << e.reason();
  }
}

}  // namespace
}  // namespace km::cli
