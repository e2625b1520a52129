// The page of a PDF report being laid out (render/pdf_report.cpp, pdf_report_plots.cpp): a
// cairo context on an A4 PDF surface, the cursor going down the page, a new page when a block does
// not fit, text in DejaVu Sans measured and wrapped to a width, the page budget and the question
// whether to give up (RenderOptions). Internal to render/.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <cairo.h>

// The blocks drawn here are the whole report's (render/pdf_report.h); the page needs only their
// names, so it does not include the report it is a part of.
namespace km::render {
struct DbbPolar;
struct ReportChart;
}  // namespace km::render

namespace km::render::pdf {

inline constexpr double kPageW = 595.28;  // A4 in points
inline constexpr double kPageH = 841.89;
inline constexpr double kMargin = 50.0;
inline constexpr double kWidth = kPageW - 2 * kMargin;

struct Rgb {
  double r = 0, g = 0, b = 0;
};

// Thrown by Page::Need when a new page would go beyond the content pages of the budget (all but
// the last page); `left_out` says what of the block being drawn is left out ("" : all of it).
struct PageBudgetReached {
  std::string left_out;
};

class Page {
 public:
  // `content_pages`: the pages content may fill (0: no budget); `cancelled` (may be empty) is
  // asked at every Need.
  Page(cairo_t* cr, std::string footer, int content_pages, std::function<bool()> cancelled)
      : cr_(cr),
        footer_(std::move(footer)),
        content_pages_(content_pages),
        cancelled_(std::move(cancelled)) {}
  cairo_t* cr() const { return cr_; }
  double y() const { return y_; }
  void Advance(double dy) { y_ += dy; }
  int number() const { return page_; }
  // Starts a new page unless `height` points still fit above the bottom margin. Throws
  // PageBudgetReached when that page is beyond the content pages, RenderCancelled when asked to.
  void Need(double height);
  void CheckCancelled() const;
  // Lifts the budget: the closing page that says what was left out.
  void EndBudget() { content_pages_ = 0; }
  void Finish();  // the foot of the last page

  void Font(double size, bool bold = false) const;
  double TextWidth(const std::string& s) const;
  void Text(double x, double baseline, const std::string& s, Rgb colour = {}) const;
  void TextRight(double right, double baseline, const std::string& s) const;
  // Lines of at most `width` points, broken at spaces (a longer word at code points).
  std::vector<std::string> Wrap(const std::string& s, double width) const;

 private:
  void Foot() const;
  cairo_t* cr_;
  std::string footer_;
  int content_pages_;
  std::function<bool()> cancelled_;
  double y_ = kMargin;
  int page_ = 1;
};

// The polar plot of a DBB test and a line chart, drawn at the cursor (pdf_report_plots.cpp).
void DrawPolar(Page& page, const DbbPolar& polar);
void DrawChart(Page& page, const ReportChart& chart);
// The heights they take on the page.
double PolarHeight(const DbbPolar& polar);
double ChartHeight(const ReportChart& chart);

}  // namespace km::render::pdf
