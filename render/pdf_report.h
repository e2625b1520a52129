// Reports a metrology lab signs, as PDF documents drawn with cairo: vector graphics, and text a
// reader can select and copy (cairo embeds the subsets of the fonts with their Unicode mapping, so
// pdftotext gives the numbers back). A report is a title, lines that identify what it is about,
// and a list of blocks — headings, paragraphs, tables, the polar plot of a DBB test, line charts,
// a signature block — laid out top to bottom on A4 pages; the foot of every page repeats the
// report's footer line with the page number. No file I/O: the PDF comes back as bytes.
#pragma once

#include <string>
#include <utility>
#include <vector>

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
struct ReportChart {
  std::string title, x_label, y_label;
  std::vector<ReportSeries> series;
  std::vector<std::pair<std::string, double>> limits;
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
};

ReportBlock HeadingBlock(std::string text);
ReportBlock ParagraphBlock(std::string text);
ReportBlock TableBlock(ReportTable table);
ReportBlock PolarBlock(DbbPolar polar);
ReportBlock ChartBlock(ReportChart chart);
ReportBlock SignatureBlock(std::vector<std::string> signers);

// The PDF bytes ("%PDF-1.5" … "%%EOF"). Throws std::runtime_error when cairo fails (its status
// named) and km::InvalidInput for a polar plot that cannot be drawn (render/polar_plot.h).
std::string RenderPdf(const Report& report);

}  // namespace km::render
