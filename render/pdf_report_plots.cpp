// The graphics of a PDF report (render/pdf_report.h) as vector paths: the polar plot of a DBB
// test, drawn as render/polar_plot.h draws its PNG (deviation d at angle θ at the radius r0 + k·d,
// rings at whole divisions, the minimum-zone circles, the same scale), and line charts; a line of
// many points is drawn from PlotPoints of it (render/pdf_report.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "render/chart_ticks.h"
#include "render/pdf_report.h"
#include "render/pdf_report_page.h"
#include "render/polar_plot.h"

namespace km::render::pdf {
namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6g", v);
  return buf;
}

void Stroke(cairo_t* cr, Rgb c, double width, bool dashed = false) {
  cairo_set_source_rgb(cr, c.r, c.g, c.b);
  cairo_set_line_width(cr, width);
  const double dash[] = {4.0, 2.5};
  cairo_set_dash(cr, dash, dashed ? 2 : 0, 0);
  cairo_stroke(cr);
  cairo_set_dash(cr, dash, 0, 0);
  cairo_set_source_rgb(cr, 0, 0, 0);
}

const Rgb kGreen{0.16, 0.63, 0.16};

// The value of a limit line in its label: 3 significant digits, whole numbers from 100 up.
std::string LimitText(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), std::fabs(v) >= 99.95 ? "%.0f" : "%.3g", v);
  return buf;
}

// The unit of a chart's y axis from its label: "gap rms (µm)" → " µm"; "" when it names none.
std::string UnitOfLabel(const std::string& label) {
  const auto open = label.rfind('(');
  if (open == std::string::npos || !label.ends_with(')')) return "";
  return " " + label.substr(open + 1, label.size() - open - 2);
}

void TextCentred(const Page& p, double x, double baseline, const std::string& s) {
  p.Text(x - p.TextWidth(s) / 2, baseline, s);
}

// Whether every finite x of the chart's series and bands is a whole number (a step number).
bool WholeX(const ReportChart& chart) {
  const auto whole = [](const std::vector<double>& xs) {
    return std::all_of(xs.begin(), xs.end(),
                       [](double x) { return !std::isfinite(x) || x == std::round(x); });
  };
  for (const auto& s : chart.series) {
    if (!whole(s.x)) return false;
  }
  for (const auto& b : chart.bands) {
    if (!whole(b.x)) return false;
  }
  return true;
}

constexpr double kPolarSize = 300.0;
constexpr double kChartH = 200.0;

}  // namespace

double PolarHeight(const DbbPolar& polar) {
  return kPolarSize + 44 + 12.0 * static_cast<double>(polar.options.notes.size());
}

double ChartHeight(const ReportChart& chart) {
  return kChartH + 16.0 * static_cast<double>(chart.series.size() / 4 + 1) + 10;
}

void DrawPolar(Page& p, const DbbPolar& polar) {
  const auto& o = polar.options;
  const auto [div, ndiv] = ChoosePolarScale(polar.traces, polar.zone, o);
  const double size = kPolarSize;
  p.Need(PolarHeight(polar));
  cairo_t* cr = p.cr();
  p.Font(10, true);
  p.Text(kMargin, p.y() + 10, o.title);
  const double cx = kMargin + kWidth / 2.0, cy = p.y() + 22 + size / 2.0;
  const double r0 = 0.30 * size, band = 0.18 * size;
  const double k = band / (ndiv * div);  // points per µm
  const auto at = [&](double theta, double d) {
    const double r = std::max(0.0, r0 + k * d);
    return std::pair{cx + r * std::cos(theta), cy - r * std::sin(theta)};
  };
  for (int i = -ndiv; i <= ndiv; ++i) {
    const double r = r0 + k * i * div;
    if (r <= 0) continue;
    cairo_new_path(cr);
    cairo_arc(cr, cx, cy, r, 0, 2 * std::numbers::pi);
    Stroke(cr, i == 0 ? Rgb{0.47, 0.47, 0.47} : Rgb{0.86, 0.86, 0.86}, i == 0 ? 0.8 : 0.5);
  }
  for (int a = 0; a < 360; a += 30) {
    const double t = a * std::numbers::pi / 180.0;
    const auto [x0, y0] = at(t, -ndiv * div);
    const auto [x1, y1] = at(t, ndiv * div);
    cairo_move_to(cr, x0, y0);
    cairo_line_to(cr, x1, y1);
    Stroke(cr, {0.86, 0.86, 0.86}, 0.5);
  }
  for (double rho : {polar.zone.inner_um, polar.zone.outer_um}) {
    for (int i = 0; i <= 720; ++i) {
      const double t = i * std::numbers::pi / 360.0;
      const auto [x, y] = at(
          t, rho + polar.zone.centre_um[0] * std::cos(t) + polar.zone.centre_um[1] * std::sin(t));
      if (i == 0) {
        cairo_move_to(cr, x, y);
      } else {
        cairo_line_to(cr, x, y);
      }
    }
    Stroke(cr, kGreen, 0.6, true);
  }
  double legend_y = p.y() + 30;
  p.Font(8);
  for (const auto& t : polar.traces) {
    bool first = true;
    for (const std::size_t i : PlotPoints(t.dev_um, kMaxPlotPoints)) {
      if (i >= t.angle_rad.size()) break;
      const auto [x, y] = at(t.angle_rad[i], t.dev_um[i]);
      if (first) {
        cairo_move_to(cr, x, y);
      } else {
        cairo_line_to(cr, x, y);
      }
      first = false;
    }
    const Rgb c{t.bgr[2] / 255.0, t.bgr[1] / 255.0, t.bgr[0] / 255.0};
    Stroke(cr, c, 0.9);
    cairo_move_to(cr, kMargin + kWidth - 70, legend_y - 3);
    cairo_line_to(cr, kMargin + kWidth - 55, legend_y - 3);
    Stroke(cr, c, 1.2);
    p.Text(kMargin + kWidth - 50, legend_y, t.label);
    legend_y += 12;
  }
  cairo_move_to(cr, kMargin + kWidth - 70, legend_y - 3);
  cairo_line_to(cr, kMargin + kWidth - 55, legend_y - 3);
  Stroke(cr, kGreen, 0.8, true);
  p.Text(kMargin + kWidth - 50, legend_y, "min. zone");
  const auto [ax, ay] = at(0.0, (ndiv + 0.5) * div);
  p.Text(ax + 2, ay + 3, "+" + o.first_axis);
  const auto [bx, by] = at(std::numbers::pi / 2.0, (ndiv + 0.5) * div);
  p.Text(bx - 6, by - 2, "+" + o.second_axis);
  p.Advance(size + 30);
  p.Font(8.5);
  p.Text(kMargin, p.y(),
         "Scale " + Num(div) +
             " µm/div; grey ring: the least-squares circle; deviations about "
             "its centre.");
  p.Advance(6);
  for (const auto& n : o.notes) {
    p.Advance(12);
    p.Text(kMargin, p.y(), n);
  }
  p.Advance(12);
}

namespace {

// Each limit's label above its line, at the right end (`right`) unless the series pass there,
// else at the left (`left`); on a white ground so a line under it does not cross its letters.
template <class Px, class Py>
void LimitLabels(Page& p, const ReportChart& chart, double left, double right, Px px, Py py) {
  cairo_t* cr = p.cr();
  for (const auto& [label, v] : chart.limits) {
    const std::string text = label + " " + LimitText(v) + UnitOfLabel(chart.y_label);
    const double w = p.TextWidth(text), base = py(v) - 2;
    const auto crowded = [&](double x0) {
      for (const auto& s : chart.series) {
        for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
          const double x = px(s.x[i]), y = py(s.y[i]);
          if (x >= x0 - 4 && x <= x0 + w + 4 && y >= base - 12 && y <= base + 4) return true;
        }
      }
      return false;
    };
    double x0 = right - w;
    if (crowded(x0) && !crowded(left)) x0 = left;
    cairo_rectangle(cr, x0 - 1, base - 8, w + 2, 10);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_fill(cr);
    p.Text(x0, base, text, {0.7, 0.12, 0.07});
    cairo_set_source_rgb(cr, 0, 0, 0);
  }
}

}  // namespace

void DrawChart(Page& p, const ReportChart& chart) {
  double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo;
  for (const auto& s : chart.series) {
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      xlo = std::min(xlo, s.x[i]);
      xhi = std::max(xhi, s.x[i]);
      ylo = std::min(ylo, s.y[i]);
      yhi = std::max(yhi, s.y[i]);
    }
  }
  if (!std::isfinite(xlo)) return;  // nothing finite to draw
  for (const auto& [label, v] : chart.limits) {
    ylo = std::min(ylo, v);
    yhi = std::max(yhi, v);
  }
  for (const auto& b : chart.bands) {
    for (std::size_t i = 0; i < b.x.size() && i < b.lo.size() && i < b.hi.size(); ++i) {
      if (!std::isfinite(b.x[i]) || !std::isfinite(b.lo[i]) || !std::isfinite(b.hi[i])) continue;
      ylo = std::min(ylo, b.lo[i]);
      yhi = std::max(yhi, b.hi[i]);
    }
  }
  if (xhi <= xlo) xhi = xlo + 1;
  const double pad = (yhi - ylo) * 0.08 + (yhi > ylo ? 0 : 0.5);
  ylo -= pad;
  yhi += pad;
  // The title, the y axis label on a line of its own (clear of the top tick's label), the plot.
  const double H = kChartH, L = 58, R = 12, T = 36, B = 32;
  p.Need(ChartHeight(chart));
  cairo_t* cr = p.cr();
  const double top = p.y();
  const auto px = [&](double x) {
    return kMargin + L + (x - xlo) / (xhi - xlo) * (kWidth - L - R);
  };
  const auto py = [&](double y) { return top + T + (1 - (y - ylo) / (yhi - ylo)) * (H - T - B); };
  p.Font(10, true);
  p.Text(kMargin, top + 11, chart.title);
  p.Font(7.5);
  const auto yt = AxisTicks(ylo, yhi, 5);
  for (double v : yt) {
    cairo_move_to(cr, kMargin + L, py(v));
    cairo_line_to(cr, kMargin + kWidth - R, py(v));
    Stroke(cr, {0.88, 0.88, 0.88}, 0.4);
    p.TextRight(kMargin + L - 4, py(v) + 2.5, TickLabel(v, yt.size() > 1 ? yt[1] - yt[0] : 1));
  }
  const auto xt = AxisTicks(xlo, xhi, 8, WholeX(chart));
  for (double v : xt) {
    TextCentred(p, px(v), top + H - B + 10, TickLabel(v, xt.size() > 1 ? xt[1] - xt[0] : 1));
  }
  cairo_rectangle(cr, kMargin + L, top + T, kWidth - L - R, H - T - B);
  Stroke(cr, {0.5, 0.5, 0.5}, 0.6);
  p.Font(8);
  p.Text(kMargin + L, top + H - 6, chart.x_label);
  p.Text(kMargin, top + 24, chart.y_label);
  for (const auto& [label, v] : chart.limits) {
    cairo_move_to(cr, kMargin + L, py(v));
    cairo_line_to(cr, kMargin + kWidth - R, py(v));
    Stroke(cr, {0.7, 0.12, 0.07}, 0.8, true);
  }
  const Rgb palette[] = {{0.04, 0.36, 0.68}, {0.71, 0.33, 0.04}, {0.06, 0.46, 0.43},
                         {0.49, 0.23, 0.93}, {0.62, 0.09, 0.30}, {0.30, 0.49, 0.06}};
  for (const auto& b : chart.bands) {
    const std::size_t n = std::min({b.x.size(), b.lo.size(), b.hi.size()});
    std::vector<std::size_t> at;
    for (std::size_t i = 0; i < n; ++i) {
      if (std::isfinite(b.x[i]) && std::isfinite(b.lo[i]) && std::isfinite(b.hi[i])) {
        at.push_back(i);
      }
    }
    if (at.size() < 2) continue;
    cairo_new_path(cr);
    for (std::size_t k = 0; k < at.size(); ++k) {
      cairo_line_to(cr, px(b.x[at[k]]), py(b.hi[at[k]]));
    }
    for (std::size_t k = at.size(); k-- > 0;) cairo_line_to(cr, px(b.x[at[k]]), py(b.lo[at[k]]));
    cairo_close_path(cr);
    const Rgb c = palette[b.series % 6];
    cairo_set_source_rgba(cr, c.r, c.g, c.b, 0.16);
    cairo_fill(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
  }
  double lx = kMargin + L, ly = top + H + 10;
  for (std::size_t k = 0; k < chart.series.size(); ++k) {
    const auto& s = chart.series[k];
    const Rgb c = palette[k % 6];
    bool first = true;
    for (const std::size_t i : PlotPoints(s.y, kMaxPlotPoints)) {
      if (i >= s.x.size() || !std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      if (first) {
        cairo_move_to(cr, px(s.x[i]), py(s.y[i]));
      } else {
        cairo_line_to(cr, px(s.x[i]), py(s.y[i]));
      }
      first = false;
    }
    Stroke(cr, c, 1.0);
    if (s.x.size() <= 80) {
      for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
        cairo_new_path(cr);
        cairo_arc(cr, px(s.x[i]), py(s.y[i]), 1.8, 0, 2 * std::numbers::pi);
        cairo_set_source_rgb(cr, c.r, c.g, c.b);
        cairo_fill(cr);
      }
    }
    if (lx + 120 > kMargin + kWidth) {
      lx = kMargin + L;
      ly += 14;
    }
    cairo_move_to(cr, lx, ly - 3);
    cairo_line_to(cr, lx + 14, ly - 3);
    Stroke(cr, c, 1.2);
    p.Text(lx + 18, ly, s.label);
    lx += 24 + std::max(80.0, p.TextWidth(s.label));
  }
  LimitLabels(p, chart, kMargin + L + 3, kMargin + kWidth - R - 3, px, py);
  p.Advance(ly - top + 12);
}

}  // namespace km::render::pdf

namespace km::render {

std::vector<double> AxisTicks(double lo, double hi, int count, bool whole_numbers) {
  const double span = hi - lo;
  if (!(span > 0) || !std::isfinite(span) || count < 1) return {lo};
  const double raw = span / count;
  const double e = std::pow(10.0, std::floor(std::log10(raw)));
  const double m = raw / e;
  double step = (m <= 1 ? 1 : m <= 2 ? 2 : m <= 5 ? 5 : 10) * e;
  if (whole_numbers) step = std::max(step, 1.0);
  std::vector<double> out;
  const double first = std::ceil(lo / step - 1e-9);
  for (double k = first; k * step <= hi + 1e-9 * step; k += 1) {
    const double v = k * step;
    out.push_back(std::abs(v) < 1e-12 * step ? 0.0 : v);
  }
  return out;
}

std::string TickLabel(double v, double step) {
  const int decimals =
      step > 0 && std::isfinite(step)
          ? std::clamp(-static_cast<int>(std::floor(std::log10(step) + 1e-9)), 0, 9)
          : 3;
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  std::string s = buf;
  if (s.starts_with('-') && s.find_first_not_of("0.", 1) == std::string::npos) s.erase(0, 1);
  return s;
}

std::vector<std::size_t> PlotPoints(const std::vector<double>& y, std::size_t max_points) {
  const std::size_t n = y.size();
  std::vector<std::size_t> out;
  if (n <= std::max<std::size_t>(max_points, 2)) {
    for (std::size_t i = 0; i < n; ++i) out.push_back(i);
    return out;
  }
  const std::size_t runs = std::max<std::size_t>(max_points / 2, 1);
  out.reserve(2 * runs);
  for (std::size_t r = 0; r < runs; ++r) {
    const std::size_t begin = r * n / runs, end = (r + 1) * n / runs;
    std::size_t lo = end, hi = end;
    for (std::size_t i = begin; i < end; ++i) {
      if (!std::isfinite(y[i])) continue;
      if (lo == end || y[i] < y[lo]) lo = i;
      if (hi == end || y[i] > y[hi]) hi = i;
    }
    if (lo == end) continue;
    out.push_back(std::min(lo, hi));
    if (lo != hi) out.push_back(std::max(lo, hi));
  }
  return out;
}

}  // namespace km::render
