#include "render/pdf_report.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include <cairo-pdf.h>
#include <cairo.h>

#include "render/pdf_report_page.h"

namespace km::render {
namespace pdf {

namespace {

constexpr const char* kFace = "DejaVu Sans";
constexpr double kFootSize = 7.5;

// The length in bytes of the UTF-8 code point starting with byte c.
std::size_t CodePointLength(unsigned char c) {
  if (c >= 0xF0) return 4;
  if (c >= 0xE0) return 3;
  if (c >= 0xC0) return 2;
  return 1;
}

// The text with every byte that does not start a well-formed UTF-8 sequence replaced by U+FFFD
// (cairo refuses a whole document over one bad string).
std::string Clean(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t n = c < 0x80                   ? 1
                    : (c >= 0xC2 && c <= 0xDF) ? 2
                    : (c >= 0xE0 && c <= 0xEF) ? 3
                    : (c >= 0xF0 && c <= 0xF4) ? 4
                                               : 0;
    bool ok = n > 0 && i + n <= s.size();
    for (std::size_t k = 1; ok && k < n; ++k)
      ok = (static_cast<unsigned char>(s[i + k]) & 0xC0) == 0x80;
    if (ok && n == 3) {  // no overlong forms, no UTF-16 surrogates
      const auto d = static_cast<unsigned char>(s[i + 1]);
      ok = !(c == 0xE0 && d < 0xA0) && !(c == 0xED && d >= 0xA0);
    }
    if (ok && n == 4) {  // no overlong forms, nothing above U+10FFFF
      const auto d = static_cast<unsigned char>(s[i + 1]);
      ok = !(c == 0xF0 && d < 0x90) && !(c == 0xF4 && d >= 0x90);
    }
    if (ok) {
      out.append(s, i, n);
      i += n;
    } else {
      out += "\xEF\xBF\xBD";
      ++i;
    }
  }
  return out;
}

}  // namespace

void Page::Font(double size, bool bold) const {
  cairo_select_font_face(cr_, kFace, CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr_, size);
}

double Page::TextWidth(const std::string& s) const {
  cairo_text_extents_t e;
  cairo_text_extents(cr_, Clean(s).c_str(), &e);
  return e.x_advance;
}

void Page::Text(double x, double baseline, const std::string& s, Rgb colour) const {
  cairo_set_source_rgb(cr_, colour.r, colour.g, colour.b);
  cairo_move_to(cr_, x, baseline);
  cairo_show_text(cr_, Clean(s).c_str());
}

void Page::TextRight(double right, double baseline, const std::string& s) const {
  Text(right - TextWidth(s), baseline, s);
}

std::vector<std::string> Page::Wrap(const std::string& s, double width) const {
  std::vector<std::string> lines;
  std::string line;
  std::size_t i = 0;
  while (i <= s.size()) {
    const std::size_t end = std::min(s.find(' ', i), s.size());
    std::string word = s.substr(i, end - i);
    const std::string candidate = line.empty() ? word : line + " " + word;
    if (TextWidth(candidate) <= width || (line.empty() && word.empty())) {
      line = candidate;
    } else {
      if (!line.empty()) lines.push_back(line);
      line.clear();
      // A word wider than the line is broken after its last '_', '/' or '-' that fits, else
      // between code points.
      while (TextWidth(word) > width && word.size() > 1) {
        std::size_t cut = 0;
        for (std::size_t k = 0; k < word.size(); k += CodePointLength(word[k])) {
          if (TextWidth(word.substr(0, k + CodePointLength(word[k]))) > width) break;
          cut = k + CodePointLength(word[k]);
        }
        if (cut == 0) cut = CodePointLength(word[0]);
        cut = std::min(cut, word.size());  // a sequence cut short at the end of the text
        const std::size_t joint = word.find_last_of("_/-", cut - 1);
        if (joint != std::string::npos && joint > 0 && joint + 1 < word.size()) cut = joint + 1;
        lines.push_back(word.substr(0, cut));
        word = word.substr(cut);
      }
      line = word;
    }
    i = end + 1;
  }
  if (!line.empty() || lines.empty()) lines.push_back(line);
  return lines;
}

void Page::Foot() const {
  Font(kFootSize);
  const std::string page = "page " + std::to_string(page_);
  cairo_set_source_rgb(cr_, 0.4, 0.4, 0.4);
  cairo_move_to(cr_, kMargin, kPageH - 28);
  cairo_show_text(cr_, Clean(footer_).c_str());
  cairo_move_to(cr_, kPageW - kMargin - TextWidth(page), kPageH - 28);
  cairo_show_text(cr_, page.c_str());
  cairo_set_source_rgb(cr_, 0, 0, 0);
}

void Page::CheckCancelled() const {
  if (cancelled_ && cancelled_()) {
    throw RenderCancelled(
        "the report was not finished: its render was cancelled (the server is "
        "stopping); retry shortly");
  }
}

void Page::Need(double height) {
  CheckCancelled();
  if (y_ + height <= kPageH - kMargin) return;
  if (content_pages_ > 0 && page_ >= content_pages_) throw PageBudgetReached{};
  Foot();
  cairo_show_page(cr_);
  ++page_;
  y_ = kMargin;
}

void Page::Finish() {
  Foot();
}

}  // namespace pdf

namespace {

using pdf::kMargin;
using pdf::kWidth;
using pdf::Page;
using pdf::PageBudgetReached;

void DrawTitle(Page& p, const Report& r) {
  p.Font(16, true);
  for (const auto& line : p.Wrap(r.title, kWidth)) {
    p.Need(22);
    p.Advance(18);
    p.Text(kMargin, p.y(), line);
    p.Advance(4);
  }
  p.Advance(6);
  double key_w = 0;
  p.Font(9, true);
  for (const auto& [k, v] : r.identification) key_w = std::max(key_w, p.TextWidth(k));
  key_w = std::min(key_w + 10, kWidth / 3);
  for (const auto& [k, v] : r.identification) {
    p.Font(9);
    const auto lines = p.Wrap(v, kWidth - key_w);
    p.Need(12.0 * static_cast<double>(lines.size()));
    p.Font(9, true);
    p.Text(kMargin, p.y() + 9, k);
    p.Font(9);
    for (const auto& line : lines) {
      p.Text(kMargin + key_w, p.y() + 9, line);
      p.Advance(12);
    }
  }
  p.Advance(8);
}

double HeadingHeight(const Page& p, const std::string& text) {
  p.Font(12, true);
  return 14 + 15.0 * static_cast<double>(p.Wrap(text, kWidth).size());
}

// A heading and `lead` points of what follows it (the first lines of the next block), kept on
// one page.
void DrawHeading(Page& p, const std::string& text, double lead) {
  p.Font(12, true);
  const auto lines = p.Wrap(text, kWidth);
  const double room = pdf::kPageH - 2 * kMargin;
  p.Need(std::min(room, HeadingHeight(p, text) + std::max(lead, 30.0)));
  p.Font(12, true);
  p.Advance(8);
  for (const auto& line : lines) {
    p.Advance(13);
    p.Text(kMargin, p.y(), line, {0.04, 0.22, 0.45});
    p.Advance(2);
  }
  p.Advance(6);
}

void DrawParagraph(Page& p, const std::string& text) {
  p.Font(9.5);
  for (const auto& line : p.Wrap(text, kWidth)) {
    p.Need(13);
    p.Text(kMargin, p.y() + 9.5, line);
    p.Advance(12.5);
  }
  p.Advance(4);
}

// The width of the widest word of a text (its parts between spaces).
double LongestWord(const Page& p, const std::string& s) {
  double most = 0;
  std::size_t i = 0;
  while (i <= s.size()) {
    const std::size_t end = std::min(s.find(' ', i), s.size());
    if (end > i) most = std::max(most, p.TextWidth(s.substr(i, end - i)));
    i = end + 1;
  }
  return most;
}

// Column widths: each column's natural width (header and the cells of the rows a budget of
// pages can hold), scaled to the page width when the sum is wider, no column under 45 pt.
std::vector<double> ColumnWidths(const Page& p, const ReportTable& t) {
  constexpr std::size_t kMeasuredRows = 2000;  // more than kMaxReportPages pages hold
  const std::size_t n = t.header.size();
  std::vector<double> w(n, 0.0);
  p.Font(8.5, true);
  for (std::size_t c = 0; c < n; ++c) w[c] = p.TextWidth(t.header[c]);
  p.Font(8.5);
  for (std::size_t r = 0; r < t.rows.size() && r < kMeasuredRows; ++r) {
    const auto& row = t.rows[r];
    if (r % 64 == 0) p.CheckCancelled();
    for (std::size_t c = 0; c < n && c < row.size(); ++c)
      w[c] = std::max(w[c], std::min(p.TextWidth(row[c]), kWidth * 0.6));
  }
  double sum = 0;
  for (auto& x : w) sum += (x += 8.0);
  if (sum <= kWidth) return w;
  // Narrower columns: each keeps its longest word (a cell wraps at spaces, not inside words)
  // when the words fit side by side.
  std::vector<double> least(n, 0.0);
  for (std::size_t c = 0; c < n; ++c) {
    p.Font(8.5, true);
    least[c] = LongestWord(p, t.header[c]);
    p.Font(8.5);
    for (std::size_t r = 0; r < t.rows.size() && r < kMeasuredRows; ++r) {
      if (c < t.rows[r].size()) least[c] = std::max(least[c], LongestWord(p, t.rows[r][c]));
    }
    least[c] = std::min(w[c], std::max(least[c] + 8.0, 45.0));
  }
  // Water-filling: every column up to a common level (its natural width at most, its longest
  // word at least), the level chosen so the columns fill the page width; short cells stay on
  // one line and the long texts share what is left.
  double floor_sum = 0;
  for (double x : least) floor_sum += x;
  if (floor_sum <= kWidth) {
    const auto filled = [&](double level) {
      double total = 0;
      for (std::size_t c = 0; c < n; ++c) total += std::max(least[c], std::min(w[c], level));
      return total;
    };
    double lo = 0, hi = kWidth;
    for (int k = 0; k < 50; ++k) {
      const double mid = (lo + hi) / 2;
      (filled(mid) > kWidth ? hi : lo) = mid;
    }
    for (std::size_t c = 0; c < n; ++c) w[c] = std::max(least[c], std::min(w[c], lo));
    return w;
  }
  for (auto& x : w) x = std::max(45.0, x * kWidth / sum);
  double again = 0;
  for (double x : w) again += x;
  for (auto& x : w) x *= kWidth / again;
  return w;
}

// The lines of each cell of a row wrapped to its column, and the row's height.
struct RowLines {
  std::vector<std::vector<std::string>> lines;
  double height = 0;
};

RowLines WrapRow(const Page& p, const std::vector<std::string>& cells, const std::vector<double>& w,
                 bool header) {
  p.Font(8.5, header);
  RowLines r;
  r.lines.resize(w.size());
  std::size_t height = 1;
  for (std::size_t c = 0; c < w.size(); ++c) {
    r.lines[c] = p.Wrap(c < cells.size() ? cells[c] : "", w[c] - 8.0);
    height = std::max(height, r.lines[c].size());
  }
  r.height = 11.0 * static_cast<double>(height) + 4.0;
  return r;
}

void DrawRow(Page& p, const RowLines& row, const std::vector<double>& w,
             const std::vector<bool>& numeric, bool header) {
  const auto& lines = row.lines;
  const double h = row.height;
  p.Font(8.5, header);
  p.Need(h);
  cairo_t* cr = p.cr();
  if (header) {
    cairo_set_source_rgb(cr, 0.92, 0.94, 0.96);
    cairo_rectangle(cr, kMargin, p.y(), kWidth, h);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
  }
  double x = kMargin;
  for (std::size_t c = 0; c < w.size(); ++c) {
    const bool right = !header && c < numeric.size() && numeric[c];
    for (std::size_t k = 0; k < lines[c].size(); ++k) {
      const double base = p.y() + 10.0 + 11.0 * static_cast<double>(k);
      if (right) {
        p.TextRight(x + w[c] - 4.0, base, lines[c][k]);
      } else {
        p.Text(x + 4.0, base, lines[c][k]);
      }
    }
    x += w[c];
  }
  p.Advance(h);
  cairo_set_source_rgb(cr, 0.8, 0.82, 0.85);
  cairo_set_line_width(cr, 0.5);
  cairo_move_to(cr, kMargin, p.y());
  cairo_line_to(cr, kMargin + kWidth, p.y());
  cairo_stroke(cr);
  cairo_set_source_rgb(cr, 0, 0, 0);
}

// The rows a table keeps together at its start (with the header) and at its end, and the
// most rows of a table that moves whole to the next page rather than break.
constexpr std::size_t kKeepRows = 3;
constexpr std::size_t kWholeTableRows = 12;

// The height of the header and rows [from, to) of a table.
double RowsHeight(const Page& p, const ReportTable& t, const std::vector<double>& w,
                  std::size_t from, std::size_t to, bool header) {
  double h = header ? WrapRow(p, t.header, w, true).height : 0.0;
  for (std::size_t i = from; i < to && i < t.rows.size(); ++i) {
    h += WrapRow(p, t.rows[i], w, false).height;
  }
  return h;
}

// What a table needs on the page it starts on: the whole of a short table (when it fits on a
// page), else its header and first rows.
double TableLead(const Page& p, const ReportTable& t, const std::vector<double>& w) {
  const double room = pdf::kPageH - 2 * kMargin;
  const std::size_t n = t.rows.size();
  if (n <= kWholeTableRows) {
    const double whole = RowsHeight(p, t, w, 0, n, true);
    if (whole <= room) return whole;
  }
  return std::min(room, RowsHeight(p, t, w, 0, kKeepRows, true));
}

void DrawTable(Page& p, const ReportTable& t) {
  if (t.header.empty()) return;
  const auto w = ColumnWidths(p, t);
  const RowLines head = WrapRow(p, t.header, w, true);
  const double lead = TableLead(p, t, w);
  p.Need(lead);
  DrawRow(p, head, w, t.numeric, true);
  const std::size_t n = t.rows.size();
  // The last rows go to a new page together, never one alone.
  const std::size_t tail = n > 2 * kKeepRows ? n - kKeepRows : n;
  for (std::size_t i = 0; i < n; ++i) {
    const RowLines row = WrapRow(p, t.rows[i], w, false);
    const int page = p.number();
    try {
      if (i == tail) p.Need(RowsHeight(p, t, w, i, n, false));
      p.Need(row.height);
    } catch (PageBudgetReached& cut) {
      cut.left_out = "rows " + std::to_string(i + 1) + " to " + std::to_string(t.rows.size()) +
                     " of the table with the column \"" + t.header.front() + "\"";
      throw;
    }
    if (p.number() != page) DrawRow(p, head, w, t.numeric, true);  // the header on each page
    DrawRow(p, row, w, t.numeric, false);
  }
  p.Advance(8);
}

void DrawSignatures(Page& p, const std::vector<std::string>& signers) {
  p.Need(24.0 + 34.0 * static_cast<double>(signers.size()));
  p.Advance(10);
  cairo_t* cr = p.cr();
  cairo_set_line_width(cr, 0.6);
  for (const auto& role : signers) {
    p.Font(9, true);
    p.Text(kMargin, p.y() + 12, role);
    p.Font(8);
    const double cols[] = {kMargin + 110, kMargin + 260, kMargin + 410};
    const char* labels[] = {"Name", "Signature", "Date"};
    for (int k = 0; k < 3; ++k) {
      cairo_move_to(cr, cols[k], p.y() + 16);
      cairo_line_to(cr, cols[k] + (k == 2 ? 85 : 140), p.y() + 16);
      cairo_stroke(cr);
      p.Text(cols[k], p.y() + 26, labels[k], {0.4, 0.4, 0.4});
    }
    p.Advance(34);
  }
}

cairo_status_t AppendBytes(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

// The first lines of a block, which the heading before it keeps on its page.
double LeadOf(const Page& p, const ReportBlock& b) {
  switch (b.kind) {
    case ReportBlock::Kind::kHeading:
      return HeadingHeight(p, b.text);
    case ReportBlock::Kind::kParagraph: {
      p.Font(9.5);
      const auto lines = std::min<std::size_t>(p.Wrap(b.text, kWidth).size(), 3);
      return 12.5 * static_cast<double>(lines) + 4;
    }
    case ReportBlock::Kind::kTable:
      return b.table.header.empty() ? 0.0 : TableLead(p, b.table, ColumnWidths(p, b.table));
    case ReportBlock::Kind::kPolar:
      return pdf::PolarHeight(b.polar);
    case ReportBlock::Kind::kChart:
      return pdf::ChartHeight(b.chart);
    case ReportBlock::Kind::kSignature:
      return 24.0 + 34.0 * static_cast<double>(b.signers.size());
  }
  return 0.0;
}

// `next`: the block after b (null: none), which a heading keeps with it.
void DrawBlock(Page& p, const ReportBlock& b, const ReportBlock* next = nullptr) {
  switch (b.kind) {
    case ReportBlock::Kind::kHeading:
      DrawHeading(p, b.text, next ? LeadOf(p, *next) : 0.0);
      break;
    case ReportBlock::Kind::kParagraph:
      DrawParagraph(p, b.text);
      break;
    case ReportBlock::Kind::kTable:
      DrawTable(p, b.table);
      break;
    case ReportBlock::Kind::kPolar:
      pdf::DrawPolar(p, b.polar);
      break;
    case ReportBlock::Kind::kChart:
      pdf::DrawChart(p, b.chart);
      break;
    case ReportBlock::Kind::kSignature:
      DrawSignatures(p, b.signers);
      break;
  }
}

// The last page of a report cut by its page budget: what was left out and where the complete
// data is, then the signature blocks (with their headings) of the blocks left out.
void DrawClosing(Page& p, const Report& r, std::size_t next, const PageBudgetReached& cut,
                 int max_pages) {
  p.EndBudget();
  std::string note = "This report ends here: it reached its limit of " + std::to_string(max_pages) +
                     " pages, and ";
  note += cut.left_out.empty() ? "what follows" : cut.left_out + " and what follows them";
  note += " is left out";
  note += r.complete_at.empty() ? "." : "; the complete data is in " + r.complete_at + ".";
  DrawHeading(p, "Report cut at its page limit", 0.0);
  DrawParagraph(p, note);
  for (std::size_t i = next; i < r.blocks.size(); ++i) {
    const bool signature = r.blocks[i].kind == ReportBlock::Kind::kSignature;
    const bool its_heading = r.blocks[i].kind == ReportBlock::Kind::kHeading &&
                             i + 1 < r.blocks.size() &&
                             r.blocks[i + 1].kind == ReportBlock::Kind::kSignature;
    if (signature || its_heading) {
      DrawBlock(p, r.blocks[i], i + 1 < r.blocks.size() ? &r.blocks[i + 1] : nullptr);
    }
  }
}

void DrawReport(Page& p, const Report& r, int max_pages) {
  std::size_t next = 0;  // the block after the one being drawn
  try {
    DrawTitle(p, r);
    for (std::size_t i = 0; i < r.blocks.size(); ++i) {
      ++next;
      DrawBlock(p, r.blocks[i], i + 1 < r.blocks.size() ? &r.blocks[i + 1] : nullptr);
    }
  } catch (const PageBudgetReached& cut) {
    DrawClosing(p, r, next, cut, max_pages);
  }
}

}  // namespace

ReportBlock HeadingBlock(std::string text) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::kHeading;
  b.text = std::move(text);
  return b;
}

ReportBlock ParagraphBlock(std::string text) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::kParagraph;
  b.text = std::move(text);
  return b;
}

ReportBlock TableBlock(ReportTable table) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::kTable;
  b.table = std::move(table);
  return b;
}

ReportBlock PolarBlock(DbbPolar polar) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::kPolar;
  b.polar = std::move(polar);
  return b;
}

ReportBlock ChartBlock(ReportChart chart) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::kChart;
  b.chart = std::move(chart);
  return b;
}

ReportBlock SignatureBlock(std::vector<std::string> signers) {
  ReportBlock b;
  b.kind = ReportBlock::Kind::kSignature;
  b.signers = std::move(signers);
  return b;
}

std::string RenderPdf(const Report& report, const RenderOptions& options) {
  const int max_pages = std::max(2, options.max_pages);
  std::string out;
  cairo_surface_t* surface =
      cairo_pdf_surface_create_for_stream(AppendBytes, &out, pdf::kPageW, pdf::kPageH);
  cairo_pdf_surface_set_metadata(surface, CAIRO_PDF_METADATA_TITLE,
                                 pdf::Clean(report.title).c_str());
  cairo_pdf_surface_set_metadata(surface, CAIRO_PDF_METADATA_CREATOR, "kinemetric");
  cairo_t* cr = cairo_create(surface);
  try {
    Page page(cr, report.footer, max_pages - 1, options.cancelled);
    DrawReport(page, report, max_pages);
    page.Finish();
  } catch (...) {
    cairo_destroy(cr);
    cairo_surface_destroy(surface);
    throw;
  }
  const cairo_status_t drawn = cairo_status(cr);
  cairo_destroy(cr);
  cairo_surface_finish(surface);
  const cairo_status_t written = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  for (const auto st : {drawn, written}) {
    if (st != CAIRO_STATUS_SUCCESS) {
      throw std::runtime_error(std::string("PDF report: cairo: ") + cairo_status_to_string(st));
    }
  }
  return out;
}

}  // namespace km::render
