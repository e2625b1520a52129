// The bounds of a PDF report (render/pdf_report.h): a report of any length ends at its page
// budget and its last page says what was left out, where the complete data is, and still
// carries the signatures; a render asked to give up stops at once, and one cancelled half-way
// through a long table stops within a fraction of a second; a line of a million points is drawn
// from at most kMaxPlotPoints of them, keeping its peaks.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "render/pdf_report.h"

namespace km::render {
namespace {

namespace fs = std::filesystem;

std::string ShellOut(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  pclose(p);
  return out;
}

class PdfReportLimits : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("km-pdf-limits-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Write(const std::string& bytes) {
    const auto path = (dir_ / "report.pdf").string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  int Pages(const std::string& path) {
    const std::string info = ShellOut("pdfinfo '" + path + "' 2>&1");
    const auto at = info.find("Pages:");
    return at == std::string::npos ? -1 : std::stoi(info.substr(at + 6));
  }
  fs::path dir_;
};

Report LongTable(int rows) {
  Report r;
  r.title = "Linear positioning — vmc-7";
  r.footer = "kinemetric · limits";
  r.complete_at = "the JSON result (GET /api/v1/measurements/7/results)";
  r.blocks.push_back(HeadingBlock("targets"));
  ReportTable t;
  t.header = {"target (mm)", "mean up (µm)"};
  t.numeric = {true, true};
  for (int i = 0; i < rows; ++i) {
    t.rows.push_back({std::to_string(i) + ".000", std::to_string(i % 7) + ".125"});
  }
  r.blocks.push_back(TableBlock(std::move(t)));
  r.blocks.push_back(ParagraphBlock("a paragraph after the table"));
  r.blocks.push_back(HeadingBlock("Signatures"));
  r.blocks.push_back(SignatureBlock({"Measured by", "Approved by"}));
  return r;
}

TEST_F(PdfReportLimits, AReportEndsAtItsPageBudgetAndSaysWhatWasLeftOut) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string path = Write(RenderPdf(LongTable(20'000)));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const int pages = Pages(path);
  EXPECT_GE(pages, kMaxReportPages - 1);
  EXPECT_LE(pages, kMaxReportPages);
  EXPECT_LT(s, 5.0) << "a render of 20 000 rows stops at its budget";
  std::string text = ShellOut("pdftotext '" + path + "' - 2>&1");
  for (auto& c : text) c = c == '\n' ? ' ' : c;
  for (const char* want :
       {"Report cut at its page limit", "limit of 30 pages", "to 20000 of the table",
        "GET /api/v1/measurements/7/results", "Approved by", "Signatures"}) {
    EXPECT_NE(text.find(want), std::string::npos) << "missing '" << want << "'";
  }
  EXPECT_EQ(text.find("a paragraph after the table"), std::string::npos);
  // A smaller budget holds too.
  RenderOptions o;
  o.max_pages = 3;
  EXPECT_EQ(Pages(Write(RenderPdf(LongTable(20'000), o))), 3);
}

TEST_F(PdfReportLimits, AShortReportIsNotCut) {
  const std::string path = Write(RenderPdf(LongTable(100)));
  EXPECT_LE(Pages(path), 4);
  const std::string text = ShellOut("pdftotext '" + path + "' - 2>&1");
  EXPECT_EQ(text.find("page limit"), std::string::npos);
  EXPECT_NE(text.find("a paragraph after the table"), std::string::npos);
}

TEST_F(PdfReportLimits, ARenderAskedToGiveUpStops) {
  RenderOptions o;
  o.cancelled = [] { return true; };
  EXPECT_THROW(RenderPdf(LongTable(10), o), RenderCancelled);
  try {
    RenderPdf(LongTable(10), o);
  } catch (const Unavailable& e) {  // HTTP 503 with Retry-After
    EXPECT_NE(std::string(e.what()).find("cancelled"), std::string::npos) << e.what();
  }
}

TEST_F(PdfReportLimits, ALongRenderIsCancelledHalfWay) {
  // Without a budget, 200 000 rows are thousands of pages (seconds); cancelled after 100 ms.
  RenderOptions o;
  o.max_pages = 1'000'000;
  const Report big = LongTable(200'000);
  const auto t1 = std::chrono::steady_clock::now();
  std::atomic<int> asked{0};
  o.cancelled = [&] {
    ++asked;
    return std::chrono::steady_clock::now() - t1 > std::chrono::milliseconds(100);
  };
  EXPECT_THROW(RenderPdf(big, o), RenderCancelled);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  EXPECT_LT(s, 1.0) << "gave up " << s << " s after the start";
  EXPECT_GT(asked.load(), 10);
}

TEST_F(PdfReportLimits, PlotPointsKeepEveryPeakOfALongLine) {
  std::vector<double> y(1'000'000);
  for (std::size_t i = 0; i < y.size(); ++i) y[i] = std::sin(static_cast<double>(i) * 1e-4);
  y[123'457] = 50.0;
  y[876'543] = -50.0;
  y[5] = std::nan("");
  const auto idx = PlotPoints(y, kMaxPlotPoints);
  EXPECT_LE(idx.size(), kMaxPlotPoints);
  EXPECT_GE(idx.size(), kMaxPlotPoints / 2);
  EXPECT_TRUE(std::is_sorted(idx.begin(), idx.end()));
  EXPECT_NE(std::find(idx.begin(), idx.end(), 123'457u), idx.end());
  EXPECT_NE(std::find(idx.begin(), idx.end(), 876'543u), idx.end());
  EXPECT_EQ(std::find(idx.begin(), idx.end(), 5u), idx.end());
  EXPECT_EQ(PlotPoints({1, 2, 3}, kMaxPlotPoints).size(), 3u);
}

TEST_F(PdfReportLimits, AChartOfAMillionPointsIsSmallAndQuick) {
  Report r;
  r.title = "chart";
  ReportChart c;
  c.title = "a long line";
  ReportSeries s{"line", {}, {}};
  for (int i = 0; i < 1'000'000; ++i) {
    s.x.push_back(i);
    s.y.push_back(std::sin(i * 1e-3));
  }
  c.series.push_back(std::move(s));
  r.blocks.push_back(ChartBlock(std::move(c)));
  DbbPolar polar;
  PolarPlotTrace t;
  t.label = "ccw";
  for (int i = 0; i < 500'000; ++i) {
    t.angle_rad.push_back(2.0 * 3.14159265358979 * i / 500'000.0);
    t.dev_um.push_back(4.0 * std::cos(2.0 * t.angle_rad.back()));
  }
  polar.traces = {t};
  polar.zone.inner_um = -4.0;
  polar.zone.outer_um = 4.0;
  r.blocks.push_back(PolarBlock(std::move(polar)));
  const auto t0 = std::chrono::steady_clock::now();
  const std::string pdf = RenderPdf(r);
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(pdf.size(), 400'000u) << "a line of 1 000 000 points drawn from a few thousand";
  EXPECT_LT(sec, 2.0);
  EXPECT_EQ(Pages(Write(pdf)), 1);
}

}  // namespace
}  // namespace km::render
