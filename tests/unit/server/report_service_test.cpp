// PDF reports of what the service stores, read back with poppler's pdftotext: a DBB test of a
// pure oval (radial error 5 µm · cos 2θ, so its circularity is 10.00 µm by the definition, no
// analysis code needed) names the machine, the date, the circularity, its partner, the audit rule
// with its limit and the verdict "level 2 — warn", and the later test of the same set-up as "as
// left"; the audit report lists every rule, value and finding; a positioning report its figures.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <vector>

#include "analysis/core/errors.h"
#include "server/audits/audit_service.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/pdf_text.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

// A DBB file of a pure oval: dr = a · cos 2θ (µm) about the commanded circle.
std::string OvalDbb(const std::string& direction, const std::string& when, double a) {
  std::ostringstream f;
  f << "# format: kinemetric-dbb/1\n# machine_id: report-vmc\n# test_id: xy-r150\n"
    << "# direction: " << direction << "\n# bar_length_mm: 150\n# centre_mm: 0, 0, 0\n"
    << "# feed_mm_min: 1000\n# timestamp: " << when << "\n# operator: A. Smith\n"
    << "# instrument: ballbar QC-7 serial 1234\nangle_deg,dr_um\n";
  for (int i = 0; i < 360; ++i) {
    const double deg = direction == "ccw" ? i : -i;
    char line[64];
    std::snprintf(line, sizeof line, "%g,%.6f\n", deg,
                  a * std::cos(2.0 * deg * std::numbers::pi / 180.0));
    f << line;
  }
  return f.str();
}

class ReportServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("km-report-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    svc_ = std::make_unique<Service>(std::make_unique<SqliteStorage>((dir_ / "db").string()),
                                     ServiceOptions{});
    RegisterBuiltinKinds(svc_->measurements());
  }
  void TearDown() override {
    svc_.reset();
    fs::remove_all(dir_);
  }
  // The text of a PDF (pdftotext, reading order as laid out).
  std::string Text(const std::string& pdf) {
    EXPECT_EQ(pdf.rfind("%PDF-", 0), 0u);
    return ::km::test::PdfToText(pdf, (dir_ / "r.pdf").string());
  }
  fs::path dir_;
  std::unique_ptr<Service> svc_;
};

TEST_F(ReportServiceTest, ADbbReportNamesMachineDateFiguresAuditAndAsLeft) {
  auto& m = svc_->measurements();
  const auto ccw = m.Upload(OvalDbb("ccw", "2026-04-01T08:00:00Z", 5.0), "ccw.txt").id;
  const auto cw = m.Upload(OvalDbb("cw", "2026-04-01T08:05:00Z", 5.0), "cw.txt").id;
  // A warn limit under the 10 µm circularity, a stop limit over it: level 2.
  PutAuditConfig(
      *svc_, "report-vmc",
      {{"schedule", nullptr},
       {"rules", {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 7.5}, {"stop", 20}}}}},
      1'775'000'000);
  const auto verdict = RunAccuracyAudit(*svc_, "report-vmc", "manual", 1'775'000'100);
  ASSERT_EQ(verdict["level"], 2);
  const std::string text = Text(svc_->reports().MeasurementPdf(ccw));
  for (const std::string& s : std::vector<std::string>{
           "report-vmc", "xy-r150", "2026-04-01T08:00:00Z", "10.00", "A. Smith",
           "ballbar QC-7 serial 1234", "Circularity F (least squares)", "level 2 — warn",
           "warn 7.5 µm, stop 20 µm", "measurement #" + to_string(cw), "Signature", "Polar plot"}) {
    EXPECT_NE(text.find(s), std::string::npos) << "missing '" << s << "' in:\n" << text;
  }
  EXPECT_EQ(text.find("As found"), std::string::npos) << "no later test yet";
  // A later CCW test of the same set-up, after a repair: as found 10.00, as left 4.00 µm. The
  // user chooses it; a later test alone does not make the report an as-found / as-left one.
  const auto after = m.Upload(OvalDbb("ccw", "2026-05-01T08:00:00Z", 2.0), "after.txt").id;
  EXPECT_EQ(Text(svc_->reports().MeasurementPdf(ccw)).find("As found"), std::string::npos);
  const std::string again = Text(svc_->reports().MeasurementPdf(ccw, {after, std::nullopt}));
  EXPECT_NE(again.find("As found / as left"), std::string::npos) << again;
  EXPECT_NE(again.find("#" + to_string(after)), std::string::npos) << again;
  EXPECT_NE(again.find("4.00"), std::string::npos) << again;
}

// Two set-ups measured in one session: each report shows the judgement of its own set-up (the
// older xy-r100 circle above stop is not "within limits" because a newer circle is).
TEST_F(ReportServiceTest, AMeasurementReportShowsTheJudgementOfItsOwnSetUp) {
  auto& m = svc_->measurements();
  std::string big = OvalDbb("cw", "2026-04-01T08:00:00Z", 20.0);
  big.replace(big.find("xy-r150"), 7, "xy-r100");
  const auto above = m.Upload(big, "r100.txt").id;
  const auto good = m.Upload(OvalDbb("ccw", "2026-04-01T08:30:00Z", 2.0), "r150.txt").id;
  PutAuditConfig(
      *svc_, "report-vmc",
      {{"rules", {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 15}, {"stop", 30}}}}},
      1'775'000'000);
  ASSERT_EQ(RunAccuracyAudit(*svc_, "report-vmc", "manual", 1'775'000'100)["level"], 3);
  const std::string text = Text(svc_->reports().MeasurementPdf(above));
  EXPECT_NE(text.find("level 3 — stop"), std::string::npos) << text;
  EXPECT_NE(text.find("xy-r100 CW"), std::string::npos) << text;
  EXPECT_EQ(text.find("within limits"), std::string::npos) << text;
  EXPECT_EQ(text.find("measurement #" + to_string(good)), std::string::npos) << text;
  const std::string other = Text(svc_->reports().MeasurementPdf(good));
  EXPECT_NE(other.find("within limits"), std::string::npos) << other;
  const std::string audit = Text(svc_->reports().AuditPdf("report-vmc"));
  EXPECT_NE(audit.find("xy-r100 CW"), std::string::npos) << audit;
  EXPECT_NE(audit.find("xy-r150 CCW"), std::string::npos) << audit;
}

TEST_F(ReportServiceTest, TheAuditReportListsRulesValuesFindingsAndHistory) {
  auto& m = svc_->measurements();
  const auto id = m.Upload(OvalDbb("ccw", "2026-04-01T08:00:00Z", 5.0), "ccw.txt").id;
  PutAuditConfig(*svc_, "report-vmc",
                 {{"schedule", "every 24h"},
                  {"rules",
                   {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 7.5}, {"stop", 20}},
                    {{"kind", "dbb"}, {"metric", "centre_offset_um"}, {"warn", 50}}}}},
                 1'775'000'000);
  RunAccuracyAudit(*svc_, "report-vmc", "manual", 1'775'000'100);
  const std::string text = Text(svc_->reports().AuditPdf("report-vmc"));
  for (const std::string& s :
       std::vector<std::string>{"Accuracy audit — report-vmc", "level 2 — warn",
                                "DBB circularity F", "DBB centre offset", "10.000", "within limits",
                                "measurement #" + to_string(id), "every 24h", "History"}) {
    EXPECT_NE(text.find(s), std::string::npos) << "missing '" << s << "' in:\n" << text;
  }
  EXPECT_THROW(svc_->reports().AuditPdf("no-such-machine"), NotFound);
  EXPECT_THROW(svc_->reports().MeasurementPdf(MeasurementId(999)), NotFound);
  EXPECT_THROW(svc_->reports().JobPdf(JobId(999)), NotFound);
}

TEST_F(ReportServiceTest, APositioningReportHoldsItsFiguresAndTargets) {
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/positioning_x.txt");
  std::stringstream ss;
  ss << in.rdbuf();
  const auto out = svc_->measurements().Upload(ss.str(), "positioning_x.txt");
  const auto results = svc_->measurements().Results(out.id);
  const std::string text = Text(svc_->reports().MeasurementPdf(out.id));
  char accuracy[32];
  std::snprintf(accuracy, sizeof accuracy, "%.3f", results["accuracy_um"].get<double>());
  // A figure without a unit of length keeps its digits: n of the air to 9 significant digits.
  char index[32];
  std::snprintf(index, sizeof index, "%.9g", results["air"]["refractive_index"].get<double>());
  ASSERT_GT(std::string(index).size(), 8u);
  for (const std::string& s :
       std::vector<std::string>{"Linear positioning (ISO 230-2)", "accuracy", std::string(accuracy),
                                "targets", "450.400", std::string(index)}) {
    EXPECT_NE(text.find(s), std::string::npos) << "missing '" << s << "' in:\n" << text;
  }
}

}  // namespace
}  // namespace km::server
