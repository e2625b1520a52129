// The format table (ingest/file_formats.h): every example recognised as its own format and by
// no other, and the second DBB format, dbb-csv (ingest/dbb_csv_parser.h), read into the same
// DbbTest as the kinemetric-dbb/1 file of the same test, with the same strictness.
#include "ingest/file_formats.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/dbb_csv_parser.h"
#include "ingest/dbb_parser.h"
#include "tests/unit/expect_error.h"
#include "usecases/dbb_report.h"

namespace km::ingest {
namespace {

using km::test::Contains;
using km::test::Expect;

std::string Read(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

const std::filesystem::path kSource = KINEMETRIC_SOURCE_DIR;
const std::filesystem::path kCsv = kSource / "tests/fixtures/dbb-csv/dbb_xy-r150_ccw.csv";
const std::filesystem::path kTxt = kSource / "data/examples/dbb_xy-r150_ccw.txt";

// Every measurement example (its format line names its format) and the dbb-csv fixture.
std::vector<std::pair<std::string, std::string>> Examples() {
  std::vector<std::pair<std::string, std::string>> out;  // bytes, format
  for (const auto& e : std::filesystem::directory_iterator(kSource / "data/examples")) {
    const std::string bytes = Read(e.path());
    if (bytes.rfind("# format: kinemetric-", 0) != 0) continue;  // JSON, stream frames, README
    out.emplace_back(bytes, bytes.substr(10, bytes.find('\n') - 10));
  }
  out.emplace_back(Read(kCsv), kDbbCsvFormat);
  return out;
}

TEST(FileFormats, EveryExampleIsRecognisedByItsOwnFormatAlone) {
  const auto examples = Examples();
  ASSERT_GE(examples.size(), 12u);
  std::set<std::string> seen;
  for (const auto& [bytes, format] : examples) {
    int claims = 0;
    for (const auto& f : FileFormats()) claims += f.recognise(bytes) ? 1 : 0;
    EXPECT_EQ(claims, 1) << format;
    EXPECT_EQ(RecogniseFormat(bytes, "example").name, format);
    seen.insert(format);
  }
  // Every format of the table has an example.
  for (const auto& f : FileFormats()) EXPECT_TRUE(seen.count(std::string(f.name))) << f.name;
}

TEST(FileFormats, RecognitionIgnoresByteOrderMarkAndBlankLines) {
  const std::string csv = Read(kCsv);
  EXPECT_EQ(RecogniseFormat("\xEF\xBB\xBF\r\n\n" + csv, "f").name, kDbbCsvFormat);
  EXPECT_EQ(RecogniseFormat("\n  #  format :  kinemetric-dbb/1 \n", "f").name, kDbbFormat);
  EXPECT_EQ(RecogniseFormat(csv, "f").kind, "dbb");
}

TEST(FileFormats, AnUnknownFileIsRefusedNamingTheKnownFormats) {
  for (const std::string bytes :
       {"# format: kinemetric-dbb/9\n", "test_id,x\nmachine_id,m\n", "", "angle_deg,dr_um\n"}) {
    const auto e = Expect<InvalidInput>([&] { RecogniseFormat(bytes, "up.csv"); });
    EXPECT_EQ(e.file(), "up.csv");
    EXPECT_EQ(e.field(), "format");
    EXPECT_TRUE(Contains(e.reason(), "kinemetric-dbb/1, kinemetric-tracker/1")) << e.reason();
    EXPECT_TRUE(Contains(e.reason(), "dbb-csv")) << e.reason();
  }
  const auto e = Expect<InvalidInput>([] { RecogniseFormat("# format: x/1\n", "f"); });
  EXPECT_EQ(e.line(), 1u);
  EXPECT_TRUE(Contains(e.reason(), "unknown format 'x/1'")) << e.reason();
}

TEST(FileFormats, ReadDbbRefusesAFileOfAnotherKind) {
  const auto e = Expect<InvalidInput>(
      [] { ReadDbb(Read(kSource / "data/examples/tracker_cube.txt"), "cube.txt"); });
  EXPECT_EQ(e.file(), "cube.txt");
  EXPECT_EQ(e.field(), "format");
  EXPECT_TRUE(Contains(e.reason(), "not a DBB test")) << e.reason();
}

TEST(DbbCsv, TheSameTestAsTheKinemetricFileGivesTheSameTestAndAnalysis) {
  const dbb::DbbTest txt = ReadDbb(Read(kTxt), "a");
  const dbb::DbbTest csv = ReadDbb(Read(kCsv), "a");
  EXPECT_EQ(csv.angle_deg, txt.angle_deg);
  EXPECT_EQ(csv.dr_um, txt.dr_um);
  EXPECT_EQ(csv.metadata, txt.metadata);
  EXPECT_EQ(csv.machine_id, txt.machine_id);
  EXPECT_EQ(csv.test_id, txt.test_id);
  EXPECT_EQ(csv.centre_mm, txt.centre_mm);
  EXPECT_EQ(csv.timestamp, txt.timestamp);
  EXPECT_EQ(csv.temperature_c, txt.temperature_c);
  EXPECT_EQ(usecases::DbbTestJson(csv).dump(), usecases::DbbTestJson(txt).dump());
  EXPECT_EQ(usecases::DbbReportJson({csv}).dump(), usecases::DbbReportJson({txt}).dump());
}

TEST(DbbCsv, TheFuzzSeedIsAValidFile) {
  const auto t = ReadDbb(Read(kSource / "tests/fuzz/corpus/dbb/csv_ccw.csv"), "seed");
  EXPECT_GE(t.angle_deg.size(), 36u);
}

std::string Csv(const std::string& header, const std::string& columns = "angle_deg,dr_um") {
  std::string s = header + columns + "\n";
  for (int i = 0; i < 36; ++i) s += std::to_string(10 * i) + "," + std::to_string(0.1 * i) + "\n";
  return s;
}

const std::string kHeader =
    "machine_id,vmc-1\ntest_id,xy\ndirection,ccw\nbar_length_mm,150\n"
    "centre_mm,\"0,0,0\"\nfeed_mm_min,1000\n";

void ExpectRefused(const std::string& bytes, std::size_t line, const std::string& field,
                   const std::string& fragment) {
  const auto e = Expect<InvalidInput>([&] { ReadDbb(bytes, "bad.csv"); });
  EXPECT_EQ(e.file(), "bad.csv");
  EXPECT_EQ(e.line(), line) << e.what();
  EXPECT_EQ(e.field(), field) << e.what();
  EXPECT_TRUE(Contains(e.reason(), fragment)) << e.what();
}

TEST(DbbCsv, ReadsTheKeysAndTheSamples) {
  const auto t = ReadDbb(Csv(kHeader + "plane,ZX\n"), "ok.csv");
  EXPECT_EQ(t.machine_id, "vmc-1");
  EXPECT_EQ(t.plane, dbb::Plane::kZX);
  EXPECT_EQ(t.angle_deg.size(), 36u);
  EXPECT_DOUBLE_EQ(t.dr_um[3], 0.3);
  // Timed rows and an extra column (checked, not kept), like §1.1: ω = 1000 / 60 / 150 rad/s.
  std::string timed = kHeader + "start_angle_deg,5\nt_s,dr_um,temp_c\n";
  for (int i = 0; i <= 60; ++i) timed += std::to_string(i) + ",0.5,20\n";
  const auto t2 = ReadDbb(timed, "timed.csv");
  ASSERT_EQ(t2.angle_deg.size(), 61u);
  EXPECT_DOUBLE_EQ(t2.angle_deg[0], 5.0);
  EXPECT_NEAR(t2.angle_deg[1] - t2.angle_deg[0], 1000.0 / 60 / 150 * 180 / 3.141592653589793, 1e-9);
}

TEST(DbbCsv, RefusesNamingFileLineAndField) {
  // A required key missing: the file as a whole (line 0), like kinemetric-dbb/1.
  ExpectRefused(Csv("machine_id,vmc-1\ntest_id,xy\ndirection,ccw\nbar_length_mm,150\n"
                    "centre_mm,\"0,0,0\"\n"),
                0, "feed_mm_min", "missing");
  // The same checks as §1.1 (the one validator): a bad number, a bad direction.
  ExpectRefused(Csv(kHeader + "radius_mm,abc\n"), 7, "radius_mm", "");
  ExpectRefused(Csv("machine_id,vmc-1\ntest_id,xy\ndirection,up\nbar_length_mm,150\n"
                    "centre_mm,\"0,0,0\"\nfeed_mm_min,1000\n"),
                3, "direction", "neither");
  std::string bad_cell = Csv(kHeader);
  bad_cell.replace(bad_cell.find("\n20,"), 4, "\n2x,");
  ExpectRefused(bad_cell, 10, "angle_deg", "not a finite decimal number");
  // A wrong column header: named on its own line.
  ExpectRefused(Csv(kHeader, "angle,dr_um"), 7, "angle_deg", "column-header row");
  ExpectRefused(Csv(kHeader, "angle_deg,dr"), 7, "dr_um", "missing");
  // Too many columns in a data row.
  std::string wide = Csv(kHeader);
  wide.replace(wide.find("\n10,"), 4, "\n10,1,");
  ExpectRefused(wide, 9, "", "expected 2 values, found 3");
  // A duplicated key, a '#' line, the machine_id line not first (called directly).
  ExpectRefused(Csv(kHeader + "test_id,again\n"), 7, "test_id", "duplicated");
  ExpectRefused(Csv(kHeader + "# note: x\n"), 7, "", "no '#' lines");
  const auto e = Expect<InvalidInput>([] { ParseDbbCsv("test_id,x\n", "f"); });
  EXPECT_EQ(e.field(), "machine_id");
}

TEST(DbbCsv, KeepsTheLimitsOfTheKinemetricFormat) {
  const auto rows = Expect<TooLarge>([] {
    DbbParseOptions o;
    o.max_samples = 10;
    ParseDbbCsv(Csv(kHeader), "big.csv", o);
  });
  EXPECT_EQ(rows.line(), 18u);  // the 11th data row
  const auto line = Expect<TooLarge>(
      [] { ReadDbb(Csv(kHeader + "operator," + std::string(5000, 'a') + "\n"), "long.csv"); });
  EXPECT_EQ(line.line(), 7u);
  TextLimits limits;
  limits.max_header_lines = 3;
  EXPECT_THROW(CheckDbbCsvLimits(Csv(kHeader), "f", limits), TooLarge);
  EXPECT_NO_THROW(CheckDbbCsvLimits(Csv(kHeader), "f", TextLimits{}));
  limits = TextLimits{};
  limits.max_cells = 70;  // 36 rows of 2 values
  const auto cells = Expect<TooLarge>([&] { CheckDbbCsvLimits(Csv(kHeader), "f", limits); });
  EXPECT_EQ(cells.line(), 43u);  // the 36th data row
  limits.max_cells = 72;
  EXPECT_NO_THROW(CheckDbbCsvLimits(Csv(kHeader), "f", limits));
}

}  // namespace
}  // namespace km::ingest
