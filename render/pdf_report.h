// Reports a metrology lab signs, as PDF documents drawn with cairo: vector graphics, and text a
// reader can select and copy (cairo embeds the subsets of the fonts with their Unicode mapping, so
// pdftotext gives the numbers back). A report is a title, lines that identify what it is about,
// and a list of blocks — headings, paragraphs, tables, the polar plot of a DBB test, line charts,
// a signature block — laid out top to bottom on A4 pages; the foot of every page repeats the
// report's footer line with the page number. A heading stays on the page of the first lines of
// what follows it, a table keeps at least its header and first 3 rows together and never leaves
// fewer than 3 rows alone on a page (a short table moves whole), and a table cell wraps at
// spaces, then after '_', '/' or '-', before it breaks a word. No file I/O: the PDF comes back as
// bytes. A report is bounded: at most RenderOptions::max_pages pages (what would go beyond is left
// out and the last page says so), the lines of a chart or polar plot drawn from at most a few
// thousand points (each run of samples by its smallest and largest value, so no peak is lost),
// and a render asks RenderOptions::cancelled between blocks, rows and pages and gives up.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "analysis/core/errors.h"
#include "render/dbb_plot.h"

namespace km::render {

struct ReportTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::vector<bool> numeric;  // per column: right-aligned numbers (missing entries: text)
};

// A line chart: series over a common x axis, and horizontal limit lines (e.g. warn, stop).
struct ReportSeries {
  std::string label;
  std::vector<double> x, y;
};
// A band between two lines over x (e.g. a mean ± 2s), filled lightly in the colour of the
// series `series` (its index in ReportChart::series).
struct ReportBand {
  std::vector<double> x, lo, hi;
  std::size_t series = 0;
};
struct ReportChart {
  std::string title, x_label, y_label;
  std::vector<ReportSeries> series;
  std::vector<std::pair<std::string, double>> limits;
  std::vector<ReportBand> bands;  // drawn under the series
};

struct ReportBlock {
  enum class Kind { kHeading, kParagraph, kTable, kPolar, kChart, kSignature };
  Kind kind = Kind::kParagraph;
  std::string text;  // heading or paragraph
  ReportTable table;
  DbbPolar polar;
  ReportChart chart;
  std::vector<std::string> signers;  // signature block: one line a role ("Measured by", …)
};

struct Report {
  std::string title;
  std::vector<std::pair<std::string, std::string>> identification;  // shown under the title
  std::vector<ReportBlock> blocks;
  std::string footer;  // at the foot of every page, before "page N"
  // Where the complete data of the report is (e.g. "the JSON result: GET …/results"): named when
  // the page budget cuts the report. Empty: not named.
  std::string complete_at;
};

// The most pages a report takes (RenderOptions::max_pages by default).
inline constexpr int kMaxReportPages = 30;
// The most points a line of a chart or a trace of a polar plot is drawn from.
inline constexpr std::size_t kMaxPlotPoints = 2000;

struct RenderOptions {
  // The page budget (at least 2): what would go beyond max_pages − 1 pages is left out; the
  // last page says what was left out and where the complete data is (Report::complete_at), and
  // carries the report's signature blocks.
  int max_pages = kMaxReportPages;
  // Asked between blocks, table rows and pages; true: the render gives up (RenderCancelled).
  std::function<bool()> cancelled;
};

// A render given up because RenderOptions::cancelled said so (e.g. the server is stopping): the
// same request may succeed later, so it is an Unavailable error (HTTP 503 with Retry-After).
class RenderCancelled : public Unavailable {
 public:
  using Unavailable::Unavailable;
};

ReportBlock HeadingBlock(std::string text);
ReportBlock ParagraphBlock(std::string text);
ReportBlock TableBlock(ReportTable table);
ReportBlock PolarBlock(DbbPolar polar);
ReportBlock ChartBlock(ReportChart chart);
ReportBlock SignatureBlock(std::vector<std::string> signers);

// The PDF bytes ("%PDF-1.5" … "%%EOF"). Throws std::runtime_error when cairo fails (its status
// named), km::InvalidInput for a polar plot that cannot be drawn (render/polar_plot.h) and
// RenderCancelled when options.cancelled says so.
std::string RenderPdf(const Report& report, const RenderOptions& options = {});

// The indices of the points a line of `y` is drawn from: all of them when there are at most
// max_points, else in each of max_points / 2 runs of consecutive points the one with the
// smallest and the one with the largest y (non-finite values skipped), in their order.
std::vector<std::size_t> PlotPoints(const std::vector<double>& y, std::size_t max_points);

}  // namespace km::render
