// The PDF report of a calibration or discovery job (GET /api/v1/jobs/{id}/report.pdf) read back
// with pdftotext: it names the machine (the job's machine_id, tests/unit/server/
// job_answer_test.cpp), states the job's state once, signs
// a discovery as an analysis, prints effect names as words, a missing value as one "—", numbers
// to 3 significant digits with their unit, and a chart of steps with whole-number ticks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "render/chart_ticks.h"
#include "render/pdf_report.h"
#include "tests/unit/server/pdf_text.h"
#include "tests/unit/server/temp_dir.h"
#include "usecases/pdf_reports.h"

namespace km::server {
namespace {

using nlohmann::json;

// A serial discovery as GET /api/v1/jobs/{id} answers it: its request names no model, the job
// names the machine of its DBB tests.
json SerialDiscoveryJob() {
  json steps = json::array();
  const std::vector<std::pair<std::string, std::vector<double>>> added = {
      {"servo_mismatch", {1.2345678, 0.4567891}},
      {"squareness_xy", {0.4567891, 0.2012345}},
      {"gravity_deflection", {0.2012345, 0.0912345}}};
  for (const auto& [effect, gap] : added) {
    steps.push_back(
        {{"added_effect", effect},
         {"evidence",
          {{"sentence", effect + " lowers the held-out gap by 61.234567 % (F = 123.456789)"},
           {"f_statistic", 123.456789}}},
         {"gap_rms_before_um", gap[0]},
         {"gap_rms_after_um", gap[1]}});
  }
  const json result = {
      {"kind", "serial"},
      {"plane", "XY"},
      {"base", {{"model", "setup_terms"}, {"gap_rms_um", 1.2345678}}},
      {"steps", steps},
      {"final_model",
       {{{"effect", "centre_offset"},
         {"value", {0.1234567, -2.345678}},
         {"unit", "µm"},
         {"sigma", {0.0123456, 0.0234567}}},
        {{"effect", "radius_error"}, {"value", nullptr}, {"unit", "µm"}, {"sigma", nullptr}},
        {{"effect", "servo_mismatch"},
         {"value", 0.987654},
         {"unit", "ms"},
         {"sigma", 0.01234},
         {"z_score", 80.1234}}}},
      {"unexplained_rms_um", 0.0912345},
      {"noise_floor_um", 0.0801026},
      {"verdict", "complete"},
      {"stop_reason", "the gap is at the noise floor"},
      {"stop_code", "noise_floor"}};
  return {{"id", 7},
          {"kind", "discovery"},
          {"status", "done"},
          {"progress", 1.0},
          {"stage", "done"},
          {"created_at", "2025-03-04T10:00:00Z"},
          {"updated_at", "2025-03-04T10:02:00Z"},
          {"request", {{"measurement_ids", {3, 4}}}},
          {"machine_id", "vmc-7"},
          {"result", result},
          {"verdict", "ok"},
          {"verdict_reasons", json::array()}};
}

// A hexapod calibration with an effect, as GET /api/v1/jobs/{id} answers it.
json CalibrationJob() {
  json strut = json::array(), strut_u = json::array(), base = json::array(), base_u = json::array();
  for (int j = 0; j < 6; ++j) {
    strut.push_back(12.3456789 * (j + 1));
    strut_u.push_back(0.0345678);
    base.push_back({1.23456789 * j, -0.98765432, 2.3456789});
    base_u.push_back({0.123456, 0.123456, 0.23456});
  }
  const json result = {{"method", "absolute"},
                       {"parameters", {{"strut_offset_um", strut}, {"base_joint_offset_um", base}}},
                       {"parameter_uncertainty_um",
                        {{"strut_offset_um", strut_u}, {"base_joint_offset_um", base_u}}},
                       {"fixed_parameters", json::array()},
                       {"residual_rms_um", 0.51234567},
                       {"condition_number", 178483.123},
                       {"iterations", 12},
                       {"converged", true},
                       {"effects",
                        {{{"effect", "gravity_deflection"},
                          {"parameters", {{"sag_um", 3.456789}}},
                          {"uncertainty", {{"sag_um", 0.0456}}}}}}};
  return {
      {"id", 8},
      {"kind", "hexapod_calibration"},
      {"status", "done"},
      {"stage", "done"},
      {"created_at", "2025-03-04T11:00:00Z"},
      {"updated_at", "2025-03-04T11:05:00Z"},
      {"request", {{"machine_id", "hexa-2"}, {"machine_version", 1}, {"measurement_ids", {5, 6}}}},
      {"machine_id", "hexa-2"},
      {"result", result},
      {"verdict", "warning"},
      {"verdict_reasons",
       {"ill-conditioned: condition number 178483 (above 10000): the tests do not tell the "
        "parameters apart"}}};
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string line; std::getline(ss, line);) out.push_back(line);
  return out;
}

// The significant digits of a number as printed ("0.0801" → 3, "178483" → 6).
std::size_t SignificantDigits(std::string n) {
  std::string digits;
  for (char c : n) {
    if (c >= '0' && c <= '9') digits += c;
  }
  const auto first = digits.find_first_not_of('0');
  return first == std::string::npos ? 1 : digits.size() - first;
}

class JobReport : public test::TempDirTest {
 protected:
  std::string Text(const render::Report& r) {
    const std::string pdf = render::RenderPdf(r);
    if (const char* keep = std::getenv("KM_KEEP_PDF")) {
      std::ofstream(std::string(keep) + "/" + r.title.substr(0, 5) + ".pdf", std::ios::binary)
          << pdf;
    }
    return km::test::PdfToText(pdf, Path("job.pdf"));
  }
};

// Lines that are not (parts of) words written as JSON keys: "servo_mism" of a broken
// "servo_mismatch" too.
std::vector<std::string> SnakeCase(const std::string& text) {
  static const std::regex kKey(R"([a-z][a-z0-9]*_[a-z0-9_]*)");
  std::vector<std::string> out;
  for (const auto& line : Lines(text)) {
    if (std::regex_search(line, kKey)) out.push_back(line);
  }
  return out;
}

void ExpectOneDashACell(const std::string& text) {
  static const std::regex kTwoDashes(R"(—\s+—)");
  for (const auto& line : Lines(text)) {
    EXPECT_FALSE(std::regex_search(line, kTwoDashes)) << "two dashes in: " << line;
  }
}

TEST_F(JobReport, ADiscoveryNamesTheMachineItsStateOnceAndItsEffectsInWords) {
  const std::string text = Text(usecases::JobPdfReport(SerialDiscoveryJob(), "2025-03-05"));
  ASSERT_NE(text.find("Model-gap discovery"), std::string::npos) << text;
  const std::regex machine_line(R"(Machine\s+vmc-7)");
  EXPECT_TRUE(std::regex_search(text, machine_line)) << text;
  EXPECT_NE(text.find("Discovery — done"), std::string::npos) << text;
  EXPECT_EQ(text.find("(done)"), std::string::npos) << text;
  // A discovery is analysed and reviewed, not calibrated.
  EXPECT_EQ(text.find("Calibrated by"), std::string::npos) << text;
  EXPECT_NE(text.find("Analysed by"), std::string::npos) << text;
  EXPECT_NE(text.find("Reviewed by"), std::string::npos) << text;
  // Effect names as words, whole in their cells.
  EXPECT_TRUE(SnakeCase(text).empty()) << SnakeCase(text).front();
  EXPECT_NE(text.find("servo mismatch"), std::string::npos) << text;
  EXPECT_NE(text.find("gravity deflection"), std::string::npos) << text;
  // The centre offset per axis with its unit; a value the study did not estimate one "—".
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(centre offset X\s+0\.123\s+0\.012\s+µm)")))
      << text;
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(centre offset Y\s+-2\.346\s+0\.023\s+µm)")))
      << text;
  EXPECT_NE(text.find("radius error (not estimated)"), std::string::npos) << text;
  ExpectOneDashACell(text);
  // The noise floor (the chart's limit line, the figures) to at most 4 significant digits, with
  // its unit.
  static const std::regex kNumber(R"(\d+(\.\d+)?)");
  std::size_t noise_lines = 0;
  for (const auto& line : Lines(text)) {
    if (line.find("noise floor") == std::string::npos) continue;
    ++noise_lines;
    const auto from = line.find("noise floor");
    const std::string rest = line.substr(from);
    for (auto it = std::sregex_iterator(rest.begin(), rest.end(), kNumber);
         it != std::sregex_iterator(); ++it) {
      EXPECT_LE(SignificantDigits(it->str()), 4u) << line;
    }
  }
  EXPECT_GE(noise_lines, 2u) << text;  // the chart's line and the figure
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(noise floor 0\.0801 µm)"))) << text;
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(noise floor\s+0\.0801\s+µm)"))) << text;
  // The chart of 3 steps is ticked at the steps, not half-way between them.
  EXPECT_EQ(text.find("1.5"), std::string::npos) << text;
  EXPECT_EQ(text.find("2.5"), std::string::npos) << text;
}

TEST_F(JobReport, ACalibrationIsSignedByWhoCalibratedAndItsFiguresAreRounded) {
  const std::string text = Text(usecases::JobPdfReport(CalibrationJob(), "2025-03-05"));
  ASSERT_NE(text.find("Hexapod calibration"), std::string::npos) << text;
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(Machine\s+hexa-2)"))) << text;
  EXPECT_NE(text.find("Calibration — done"), std::string::npos) << text;
  EXPECT_EQ(text.find("(done)"), std::string::npos) << text;
  EXPECT_NE(text.find("Calibrated by"), std::string::npos) << text;
  EXPECT_EQ(text.find("Analysed by"), std::string::npos) << text;
  EXPECT_TRUE(SnakeCase(text).empty()) << SnakeCase(text).front();
  EXPECT_NE(text.find("gravity deflection"), std::string::npos) << text;
  // Values to the decimals of their σ, each strut and base joint component on its row.
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(strut offset 2\s+24\.691\s+0\.035\s+µm)")))
      << text;
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(base joint offset 2 x\s+1\.23\s+0\.12\s+µm)")))
      << text;
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(residual rms\s+0\.512\s+µm)"))) << text;
  EXPECT_EQ(text.find("0.51234567"), std::string::npos) << text;
  ExpectOneDashACell(text);
}

TEST_F(JobReport, AJobWhoseMachineIsNotKnownSaysSo) {
  json job = SerialDiscoveryJob();
  job.erase("machine_id");
  job["machine_id"] = nullptr;
  const std::string text = Text(usecases::JobPdfReport(job, "2025-03-05"));
  EXPECT_NE(text.find("not recorded with the job"), std::string::npos) << text;
}

TEST(JobReportTicks, StepAxesAreTickedAtWholeNumbersWithNiceSteps) {
  using render::AxisTicks;
  EXPECT_EQ(AxisTicks(0, 3, 8, true), (std::vector<double>{0, 1, 2, 3}));
  EXPECT_EQ(AxisTicks(1, 3, 8, true), (std::vector<double>{1, 2, 3}));
  EXPECT_EQ(AxisTicks(0, 40, 8, true), (std::vector<double>{0, 5, 10, 15, 20, 25, 30, 35, 40}));
  // Other axes: 1, 2 or 5 × 10^k.
  EXPECT_EQ(AxisTicks(0, 3, 8), (std::vector<double>{0, 0.5, 1, 1.5, 2, 2.5, 3}));
  for (const auto& [lo, hi] : std::vector<std::pair<double, double>>{
           {0, 37}, {-0.013, 0.71}, {2.5, 1234.0}, {0.0801, 1.31}}) {
    const auto t = AxisTicks(lo, hi, 5);
    ASSERT_GE(t.size(), 2u) << lo << " " << hi;
    const double step = t[1] - t[0];
    const double e = std::pow(10.0, std::floor(std::log10(step) + 1e-9));
    const double m = step / e;
    EXPECT_TRUE(std::abs(m - 1) < 1e-9 || std::abs(m - 2) < 1e-9 || std::abs(m - 5) < 1e-9) << step;
    EXPECT_GE(t.front(), lo - 1e-12);
    EXPECT_LE(t.back(), hi + 1e-12);
  }
  EXPECT_EQ(render::TickLabel(0.30000000000000004, 0.1), "0.3");
  EXPECT_EQ(render::TickLabel(-0.0, 1), "0");
  EXPECT_EQ(render::TickLabel(2, 1), "2");
}

// A chart whose x axis is a step number, drawn: ticks at 1, 2, 3 only.
TEST_F(JobReport, AChartOfStepsIsTickedAtTheSteps) {
  render::Report r;
  r.title = "Ticks";
  render::ReportChart c;
  c.title = "Steps";
  c.x_label = "step";
  c.y_label = "gap (µm)";
  c.series.push_back({"gap", {1, 2, 3}, {10, 20, 30}});
  r.blocks.push_back(render::ChartBlock(std::move(c)));
  const std::string text = Text(r);
  EXPECT_EQ(text.find("1.5"), std::string::npos) << text;
  EXPECT_EQ(text.find("2.5"), std::string::npos) << text;
}

}  // namespace
}  // namespace km::server
