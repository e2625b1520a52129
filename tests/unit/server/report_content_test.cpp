// The PDF reports read as a lab's certificate, checked on their text (poppler's pdftotext) and
// their pages (pdftoppm): a laser positioning report of the example file with stated input
// uncertainties has the deviation chart, the ISO 230-2 letters in the standard's order with µm,
// U and k, the VDI/DGQ 3441 figures, the conditions with ppm/K and its targets on one page; the
// DBB report of the example pair has no raw key, no "um", no "-0.00", its heading on the page
// of its table and the page's plot scale; the audit report says "on request" and gives its
// limits with units.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "server/audits/audit_service.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/pdf_text.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

std::string Example(const std::string& name) {
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/" + name);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Words written as JSON keys are (snake_case), outside file names and paths.
std::vector<std::string> RawKeys(const std::string& text) {
  static const std::regex kKey(R"((^|[\s(,;:])([a-z][a-z0-9]*_[a-z0-9_]+)(?=[\s),;:.]|$))");
  std::vector<std::string> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), kKey); it != std::sregex_iterator();
       ++it) {
    out.push_back((*it)[2].str());
  }
  return out;
}

class ReportContentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("km-report-content-" + std::to_string(::getpid()) + "-" +
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
  // The text of a PDF, pages separated by form feeds; every page renders as an image.
  std::string Text(const std::string& pdf) {
    const std::string text = ::km::test::PdfToText(pdf, (dir_ / "r.pdf").string());
    for (const auto& e : fs::directory_iterator(dir_)) {
      if (e.path().extension() == ".png") fs::remove(e.path());
    }
    const std::string prefix = (dir_ / "page").string();
    EXPECT_EQ(std::system(("pdftoppm -r 30 -png '" + (dir_ / "r.pdf").string() + "' '" + prefix +
                           "' 2>/dev/null")
                              .c_str()),
              0);
    std::size_t pages = 0, images = 0;
    for (std::size_t at = 0; (at = text.find('\f', at)) != std::string::npos; ++at) ++pages;
    for (const auto& e : fs::directory_iterator(dir_)) {
      if (e.path().extension() == ".png" && e.file_size() > 0) ++images;
    }
    EXPECT_EQ(images, pages) << "a page did not render";
    return text;
  }
  fs::path dir_;
  std::unique_ptr<Service> svc_;
};

TEST_F(ReportContentTest, APositioningReportReadsLikeALaserCalibrationReport) {
  std::string file = Example("positioning_x.txt");
  file.insert(file.find('\n') + 1,
              "# u_laser_ppm: 0.35\n# u_material_temperature_c: 0.15\n"
              "# u_air_temperature_c: 0.1\n# u_expansion_ppm_per_k: 1\n");
  const auto id = svc_->measurements().Upload(file, "laser.txt").id;
  const std::string text = Text(svc_->reports().MeasurementPdf(id));
  for (const char* s :
       {"Deviation chart", "Target position (mm)", "Figures (ISO 230-2:2014)",
        "Figures (VDI/DGQ 3441)", "Uncertainty of the figures", "Conditions of the measurement",
        "11.50 ppm/K", "Air temperature", "Refractive index of the air", "Targets"}) {
    EXPECT_NE(text.find(s), std::string::npos) << "missing '" << s << "' in:\n" << text;
  }
  EXPECT_EQ(text.find("1/K"), std::string::npos) << text;
  // Every letter of ISO 230-2 on its line with µm, U and k, in the standard's order.
  std::size_t at = text.find("Figures (ISO 230-2:2014)");
  for (const char* letter : {"A", "A↑", "A↓", "E", "E↑", "E↓", "M", "B", "B̄", "R", "R↑", "R↓"}) {
    const std::regex line(std::string("\\n\\s*") + letter +
                          R"(\s+[A-Z][^\n]*\s\d+\.\d{3} µm\s+± \d+\.\d{3} µm \(k = 2\))");
    std::smatch m;
    const std::string rest = text.substr(at);
    ASSERT_TRUE(std::regex_search(rest, m, line)) << letter << " in:\n" << rest;
    at += static_cast<std::size_t>(m.position(0)) + 1;
  }
  for (const char* symbol : {"P ", "Ps ", "U ", "Pa "}) {
    EXPECT_TRUE(std::regex_search(text, std::regex(std::string("\\n\\s*") + symbol +
                                                   R"(\s*[A-Z][^\n]*µm\s+± [^\n]*\(k = 2\))")))
        << symbol << text;
  }
  EXPECT_TRUE(RawKeys(text).empty()) << RawKeys(text).front() << " in:\n" << text;
  // The targets are on one page with their heading: the first and the last target.
  const std::size_t heading = text.find("\nTargets\n");
  ASSERT_NE(heading, std::string::npos);
  const std::string page = text.substr(heading, text.find('\f', heading) - heading);
  EXPECT_NE(page.find("  0.000"), std::string::npos) << page;
  EXPECT_NE(page.find("500.000"), std::string::npos) << page;
}

TEST_F(ReportContentTest, TheDbbReportOfTheExamplePairPrintsWordsNotKeys) {
  auto& m = svc_->measurements();
  const auto ccw = m.Upload(Example("dbb_xy-r150_ccw.txt"), "ccw.txt").id;
  m.Upload(Example("dbb_xy-r150_cw.txt"), "cw.txt");
  PutAuditConfig(*svc_, "vmc-3axis",
                 {{"rules",
                   {{{"kind", "dbb"}, {"metric", "circular_hysteresis_um"}, {"warn", 10.25}},
                    {{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 15}, {"stop", 40}}}}},
                 1'775'000'000);
  RunAccuracyAudit(*svc_, "vmc-3axis", "manual", 1'775'000'100);
  const std::string text = Text(svc_->reports().MeasurementPdf(ccw));
  EXPECT_TRUE(RawKeys(text).empty()) << RawKeys(text).front() << " in:\n" << text;
  for (const char* s : {"centre corrected, over a full turn", "Circular hysteresis H",
                        "warn 10.25 µm", "Scale 5 µm/div", "Servo mismatch"}) {
    EXPECT_NE(text.find(s), std::string::npos) << "missing '" << s << "' in:\n" << text;
  }
  EXPECT_FALSE(std::regex_search(text, std::regex(R"(\bum\b)"))) << text;
  EXPECT_FALSE(std::regex_search(text, std::regex(R"(-0\.0+(?![0-9]))"))) << text;
  EXPECT_EQ(text.find("0.000 ms"), std::string::npos) << "σ with 2 significant digits:\n" << text;
  // No heading is the last line of a page.
  std::stringstream pages(text);
  for (std::string page; std::getline(pages, page, '\f');) {
    const auto figures = page.find("Figures (ISO 230-4");
    if (figures == std::string::npos) continue;
    EXPECT_NE(page.find("Circularity F", figures), std::string::npos) << page;
  }
  const std::string audit = Text(svc_->reports().AuditPdf("vmc-3axis"));
  for (const char* s : {"on request", "warn 15 µm, stop 40 µm", "warn 10.25 µm"}) {
    EXPECT_NE(audit.find(s), std::string::npos) << "missing '" << s << "' in:\n" << audit;
  }
  EXPECT_EQ(audit.find("manual"), std::string::npos) << audit;
  EXPECT_FALSE(std::regex_search(audit, std::regex(R"(\d\.\d{4})"))) << audit;
  EXPECT_TRUE(RawKeys(audit).empty()) << RawKeys(audit).front() << " in:\n" << audit;
}

}  // namespace
}  // namespace km::server
