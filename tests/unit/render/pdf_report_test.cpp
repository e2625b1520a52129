// PDF reports: a real PDF (poppler's pdfinfo, pdftotext and pdftoppm read and render it), its text
// extractable with the numbers as written, long tables continued on further pages with their
// header, the polar plot drawn where the magnified geometry puts it (pixels of the rendered page).
#include "render/pdf_report.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

namespace km::render {
namespace {

namespace fs = std::filesystem;

// Output of a command (stdout), run by the shell.
std::string Shell(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  pclose(p);
  return out;
}

class PdfReport : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("km-pdf-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Write(const std::string& bytes) {
    const auto path = (dir_ / "report.pdf").string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  fs::path dir_;
};

DbbPolar OvalPolar() {
  DbbPolar p;
  PolarPlotTrace t;
  t.label = "ccw";
  t.bgr = {255, 0, 0};  // blue
  for (int i = 0; i < 720; ++i) {
    const double a = 2.0 * std::numbers::pi * i / 720.0;
    t.angle_rad.push_back(a);
    t.dev_um.push_back(4.0 * std::cos(2.0 * a));
  }
  p.traces = {t};
  p.zone.inner_um = -4.0;
  p.zone.outer_um = 4.0;
  p.options.title = "DBB xy-r150 XY";
  p.options.notes = {"ccw: circularity 8.00 um"};
  return p;
}

Report Sample(int rows) {
  Report r;
  r.title = "DBB circular test — vmc-7, xy-r150 CCW";
  r.identification = {{"Machine", "vmc-7"}, {"Measured", "2026-04-01T08:00:00Z"}};
  r.footer = "kinemetric · test report";
  r.blocks.push_back(HeadingBlock("Figures (ISO 230-4, tool-path units)"));
  ReportTable t;
  t.header = {"Figure", "CCW", "Unit"};
  t.numeric = {false, true, false};
  for (int i = 0; i < rows; ++i) {
    t.rows.push_back({"row " + std::to_string(i), std::to_string(i) + ".125", "µm"});
  }
  t.rows.push_back({"Circularity F (least squares)", "18.49", "µm"});
  r.blocks.push_back(TableBlock(t));
  r.blocks.push_back(ParagraphBlock("Verdict: level 2 — warn (audit #3 of 2026-04-02)."));
  r.blocks.push_back(PolarBlock(OvalPolar()));
  ReportChart c;
  c.title = "gap";
  c.x_label = "step";
  c.y_label = "µm";
  c.series = {{"gap rms", {0, 1, 2}, {3.2, 1.1, 0.4}}};
  c.limits = {{"noise floor", 0.35}};
  r.blocks.push_back(ChartBlock(c));
  r.blocks.push_back(SignatureBlock({"Measured by", "Approved by"}));
  return r;
}

TEST_F(PdfReport, IsAPdfWhoseTextAndNumbersAreExtractable) {
  const std::string pdf = RenderPdf(Sample(5));
  ASSERT_GT(pdf.size(), 1000u);
  EXPECT_EQ(pdf.rfind("%PDF-", 0), 0u);
  EXPECT_NE(pdf.find("%%EOF", pdf.size() - 16), std::string::npos);
  const std::string path = Write(pdf);
  const std::string info = Shell("pdfinfo '" + path + "' 2>&1");
  EXPECT_NE(info.find("Pages:"), std::string::npos) << info;
  EXPECT_NE(info.find("kinemetric"), std::string::npos) << info;  // the creator
  const std::string text = Shell("pdftotext -layout '" + path + "' - 2>&1");
  for (const char* s : {"vmc-7", "2026-04-01T08:00:00Z", "Circularity F (least squares)", "18.49",
                        "µm", "level 2 — warn", "Measured by", "Signature", "3.125", "page 1"}) {
    EXPECT_NE(text.find(s), std::string::npos) << "missing '" << s << "' in:\n" << text;
  }
}

TEST_F(PdfReport, TextThatIsNotUtf8IsDrawnWithReplacementCharacters) {
  Report r;
  r.title = "machine \xff\xfe lathe";
  r.blocks.push_back(ParagraphBlock("cut short \xe2\x82"));
  ReportTable t;
  t.header = {
      "a\xc0\xaf"
      "b"};
  t.rows = {{"\xed\xa0\x80 surrogate"}};
  r.blocks.push_back(TableBlock(t));
  const std::string text = Shell("pdftotext '" + Write(RenderPdf(r)) + "' - 2>&1");
  EXPECT_NE(text.find("machine \xEF\xBF\xBD\xEF\xBF\xBD lathe"), std::string::npos) << text;
  EXPECT_NE(text.find("surrogate"), std::string::npos) << text;
}

TEST_F(PdfReport, LongTablesContinueOnNewPagesWithTheirHeader) {
  const std::string path = Write(RenderPdf(Sample(150)));
  const std::string info = Shell("pdfinfo '" + path + "' 2>&1");
  const auto at = info.find("Pages:");
  ASSERT_NE(at, std::string::npos) << info;
  EXPECT_GE(std::stoi(info.substr(at + 6)), 3) << info;
  const std::string page2 = Shell("pdftotext -f 2 -l 2 '" + path + "' - 2>&1");
  EXPECT_NE(page2.find("Figure"), std::string::npos) << "the header again on page 2:\n" << page2;
  EXPECT_NE(page2.find("page 2"), std::string::npos);
  const std::string all = Shell("pdftotext '" + path + "' - 2>&1");
  for (int i : {0, 77, 149}) {
    EXPECT_NE(all.find("row " + std::to_string(i) + "\n"), std::string::npos) << i;
  }
}

TEST_F(PdfReport, RendersAndThePolarTraceIsWhereItsDeviationPutsIt) {
  Report r;
  r.title = "polar";
  r.blocks.push_back(PolarBlock(OvalPolar()));
  const std::string path = Write(RenderPdf(r));
  // 144 dpi: two pixels a point.
  Shell("pdftoppm -png -r 144 -f 1 -l 1 '" + path + "' '" + (dir_ / "page").string() + "'");
  std::string png;
  for (const auto& e : fs::directory_iterator(dir_)) {
    if (e.path().extension() == ".png") png = e.path().string();
  }
  ASSERT_FALSE(png.empty()) << "pdftoppm wrote no page";
  const cv::Mat img = cv::imread(png, cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  // The page lays the plot out as pdf_report_plots.cpp does: centre at x = page width / 2, the
  // square of 300 pt starting under the title; the scale for ±4 µm is 2 µm/div, 2 divisions,
  // reference radius 90 pt and 54 pt for the band: +4 µm at θ = 0 is 144 pt right of the centre,
  // −4 µm at θ = 90° is 36 pt above it.
  const auto blue_near = [&](double x_pt, double y_pt) {
    for (int dy = -4; dy <= 4; ++dy) {
      for (int dx = -4; dx <= 4; ++dx) {
        const auto& px = img.at<cv::Vec3b>(static_cast<int>(std::lround(2 * y_pt)) + dy,
                                           static_cast<int>(std::lround(2 * x_pt)) + dx);
        if (px[0] > 150 && px[1] < 120 && px[2] < 120) return true;
      }
    }
    return false;
  };
  // Find the centre's row: the title ends at y ≈ 50 + 22 (its line) + 6 + 8 (spacing).
  bool found = false;
  for (double cy = 200; cy < 320 && !found; cy += 0.5) {
    found = blue_near(595.28 / 2 + 144, cy) && blue_near(595.28 / 2, cy - 36) &&
            blue_near(595.28 / 2 - 144, cy) && blue_near(595.28 / 2, cy + 36);
  }
  EXPECT_TRUE(found) << "the oval's extremes not at the radii its deviations give";
}

}  // namespace
}  // namespace km::render
