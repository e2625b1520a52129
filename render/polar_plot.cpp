#include "render/polar_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/core/errors.h"
#include "render/png.h"

namespace km::render {

namespace {

double NiceStep(double x) {
  if (!(x > 0.0)) return 1.0;
  const double e = std::pow(10.0, std::floor(std::log10(x)));
  const double m = x / e;
  const double n = m <= 1.0 ? 1.0 : (m <= 2.0 ? 2.0 : (m <= 5.0 ? 5.0 : 10.0));
  return n * e;
}

std::string Fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

}  // namespace

PolarScale ChoosePolarScale(const std::vector<PolarPlotTrace>& traces,
                            const std::optional<PolarPlotZone>& zone, const PolarPlotOptions& o) {
  if (!(o.um_per_div >= 0.0) || !std::isfinite(o.um_per_div)) {
    throw InvalidInput("", 0, "um_per_div", "must be a positive number (or 0: automatic)");
  }
  if (o.divisions < 0 || o.divisions > 50) {
    throw InvalidInput("", 0, "divisions", "must be within 1…50 (or 0: automatic)");
  }
  if (traces.empty()) throw InvalidInput("", 0, "traces", "nothing to plot");
  double dmax = 0.0;
  for (const auto& t : traces) {
    if (t.angle_rad.size() != t.dev_um.size()) {
      throw InvalidInput("", 0, "traces", "angle and deviation sizes differ");
    }
    for (double d : t.dev_um) dmax = std::max(dmax, std::abs(d));
  }
  if (zone) dmax = std::max({dmax, std::abs(zone->inner_um), std::abs(zone->outer_um)});
  PolarScale s;
  s.um_per_div = o.um_per_div > 0.0 ? o.um_per_div : NiceStep(std::max(dmax, 1e-3) / 2.0);
  s.divisions = o.divisions > 0
                    ? o.divisions
                    : std::max(1, static_cast<int>(std::ceil(dmax / s.um_per_div - 1e-9)));
  return s;
}

std::vector<unsigned char> RenderPolarPlot(const std::vector<PolarPlotTrace>& traces,
                                           const std::optional<PolarPlotZone>& zone,
                                           const PolarPlotOptions& o) {
  if (o.size_px < 200) throw InvalidInput("", 0, "size_px", "at least 200 pixels");
  const auto [div, ndiv] = ChoosePolarScale(traces, zone, o);
  const double size = o.size_px;
  const double r0 = 0.27 * size;         // reference circle (deviation 0)
  const double band = 0.17 * size;       // ± band for ndiv divisions
  const double k = band / (ndiv * div);  // px per µm
  const cv::Point2d c(size / 2.0, size / 2.0 + 0.02 * size);
  cv::Mat img(o.size_px, o.size_px, CV_8UC3, cv::Scalar(255, 255, 255));
  auto to_px = [&](double theta, double d) {
    const double r = std::max(0.0, r0 + k * d);
    return cv::Point(static_cast<int>(std::lround(c.x + r * std::cos(theta))),
                     static_cast<int>(std::lround(c.y - r * std::sin(theta))));
  };
  const int thin = std::max(1, o.size_px / 800);
  const double font = 0.45 * size / 800.0;
  // Grid: rings at whole divisions, spokes every 30°.
  for (int i = -ndiv; i <= ndiv; ++i) {
    const int rr = static_cast<int>(std::lround(r0 + k * i * div));
    if (rr <= 0) continue;
    cv::circle(img, cv::Point(static_cast<int>(c.x), static_cast<int>(c.y)), rr,
               i == 0 ? cv::Scalar(120, 120, 120) : cv::Scalar(220, 220, 220), thin, cv::LINE_AA);
  }
  for (int a = 0; a < 360; a += 30) {
    const double t = a * std::numbers::pi / 180.0;
    cv::line(img, to_px(t, -ndiv * div), to_px(t, ndiv * div), cv::Scalar(220, 220, 220), thin,
             cv::LINE_AA);
  }
  // Minimum-zone circles.
  if (zone) {
    for (double rho : {zone->inner_um, zone->outer_um}) {
      std::vector<cv::Point> pts;
      for (int i = 0; i < 720; ++i) {
        const double t = i * std::numbers::pi / 360.0;
        pts.push_back(
            to_px(t, rho + zone->centre_um[0] * std::cos(t) + zone->centre_um[1] * std::sin(t)));
      }
      cv::polylines(img, pts, true, cv::Scalar(40, 160, 40), thin, cv::LINE_AA);
    }
  }
  // Traces.
  int legend_y = static_cast<int>(0.05 * size);
  for (const auto& t : traces) {
    std::vector<cv::Point> pts;
    pts.reserve(t.angle_rad.size());
    for (std::size_t i = 0; i < t.angle_rad.size(); ++i)
      pts.push_back(to_px(t.angle_rad[i], t.dev_um[i]));
    const cv::Scalar col(t.bgr[0], t.bgr[1], t.bgr[2]);
    cv::polylines(img, pts, false, col, thin + 1, cv::LINE_AA);
    cv::line(img, cv::Point(static_cast<int>(0.75 * size), legend_y - 4),
             cv::Point(static_cast<int>(0.80 * size), legend_y - 4), col, thin + 1, cv::LINE_AA);
    cv::putText(img, t.label, cv::Point(static_cast<int>(0.81 * size), legend_y),
                cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), thin, cv::LINE_AA);
    legend_y += static_cast<int>(0.03 * size);
  }
  if (zone) {
    cv::line(img, cv::Point(static_cast<int>(0.75 * size), legend_y - 4),
             cv::Point(static_cast<int>(0.80 * size), legend_y - 4), cv::Scalar(40, 160, 40), thin,
             cv::LINE_AA);
    cv::putText(img, "min. zone", cv::Point(static_cast<int>(0.81 * size), legend_y),
                cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), thin, cv::LINE_AA);
  }
  // Labels: title, scale, axes.
  if (!o.title.empty()) {
    cv::putText(img, o.title,
                cv::Point(static_cast<int>(0.03 * size), static_cast<int>(0.05 * size)),
                cv::FONT_HERSHEY_SIMPLEX, 1.3 * font, cv::Scalar(0, 0, 0), thin, cv::LINE_AA);
  }
  for (std::size_t i = 0; i < o.notes.size(); ++i) {
    const double y = 0.97 - 0.03 * static_cast<double>(o.notes.size() - i);
    cv::putText(img, o.notes[i],
                cv::Point(static_cast<int>(0.03 * size), static_cast<int>(y * size)),
                cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), thin, cv::LINE_AA);
  }
  cv::putText(img,
              "scale " + Fmt(div) + " um/div, " + Fmt(std::round(k * 100.0) / 100.0) +
                  " px/um (grey ring: least-squares circle)",
              cv::Point(static_cast<int>(0.03 * size), static_cast<int>(0.97 * size)),
              cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), thin, cv::LINE_AA);
  cv::putText(img, "+" + o.first_axis, to_px(0.0, (ndiv + 0.4) * div), cv::FONT_HERSHEY_SIMPLEX,
              font, cv::Scalar(0, 0, 0), thin, cv::LINE_AA);
  cv::putText(img, "+" + o.second_axis, to_px(std::numbers::pi / 2.0, (ndiv + 0.6) * div),
              cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), thin, cv::LINE_AA);
  return EncodePngBgr(img.ptr<unsigned char>(0), img.cols, img.rows, img.step[0]);
}

}  // namespace km::render
