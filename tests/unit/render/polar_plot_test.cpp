// Polar plot: valid PNG of the requested size, traces drawn in their colours where the
// magnified geometry puts them.
#include "render/polar_plot.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/core/errors.h"

namespace km::render {
namespace {

TEST(PolarPlot, DrawsTracesAndZone) {
  PolarPlotTrace t;
  t.label = "ccw";
  t.bgr = {255, 0, 0};  // pure blue, not used by the grid
  for (int i = 0; i < 3600; ++i) {
    const double a = 2.0 * std::numbers::pi * i / 3600.0;
    t.angle_rad.push_back(a);
    t.dev_um.push_back(3.0 * std::cos(2.0 * a));
  }
  PolarPlotZone z;
  z.inner_um = -3.0;
  z.outer_um = 3.0;
  PolarPlotOptions o;
  o.size_px = 600;
  o.title = "test";
  const auto png = RenderPolarPlot({t}, z, o);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(png[1], 'P');
  EXPECT_EQ(png[2], 'N');
  EXPECT_EQ(png[3], 'G');
  const cv::Mat img = cv::imdecode(png, cv::IMREAD_COLOR);
  ASSERT_EQ(img.rows, 600);
  ASSERT_EQ(img.cols, 600);
  // The trace at θ = 0 has d = +3 µm (outer edge of the band); at θ = 90° d = −3 µm.
  // Scale: 3 µm → 2 µm/div (1-2-5), 2 divisions; r = r0 + k d with r0 = 0.27·size and
  // k = 0.17·size / (2 div · 2 µm).
  const double size = 600.0, r0 = 0.27 * size, k = 0.17 * size / 4.0;
  const cv::Point2d c(size / 2.0, size / 2.0 + 0.02 * size);
  auto blue_near = [&](double theta, double d) {
    const double r = r0 + k * d;
    const int x = static_cast<int>(std::lround(c.x + r * std::cos(theta)));
    const int y = static_cast<int>(std::lround(c.y - r * std::sin(theta)));
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        const auto p = img.at<cv::Vec3b>(y + dy, x + dx);
        if (p[0] > 150 && p[1] < 100 && p[2] < 100) return true;
      }
    return false;
  };
  EXPECT_TRUE(blue_near(0.0, 3.0));
  EXPECT_TRUE(blue_near(std::numbers::pi / 2.0, -3.0));
  EXPECT_FALSE(blue_near(0.0, -3.0));
}

TEST(PolarPlot, FixedScaleIsTheSameForSmallAndLargeTraces) {
  // 1 µm/div with 4 divisions: k = 0.17·size / 4 µm whatever the traces' size, so a 1 µm and a
  // 3 µm trace are drawn at the radii of one scale (before/after comparison).
  const double size = 600.0, r0 = 0.27 * size, k = 0.17 * size / 4.0;
  const cv::Point2d c(size / 2.0, size / 2.0 + 0.02 * size);
  for (double amp : {1.0, 3.0}) {
    PolarPlotTrace t;
    t.bgr = {255, 0, 0};
    for (int i = 0; i < 3600; ++i) {
      t.angle_rad.push_back(2.0 * std::numbers::pi * i / 3600.0);
      t.dev_um.push_back(amp);
    }
    PolarPlotOptions o;
    o.size_px = 600;
    o.um_per_div = 1.0;
    o.divisions = 4;
    o.notes = {"ccw: circularity 0.00 um"};
    const cv::Mat img = cv::imdecode(RenderPolarPlot({t}, std::nullopt, o), cv::IMREAD_COLOR);
    const int x = static_cast<int>(std::lround(c.x + r0 + k * amp));
    const int y = static_cast<int>(std::lround(c.y));
    bool blue = false;
    for (int dx = -2; dx <= 2; ++dx) {
      const auto p = img.at<cv::Vec3b>(y, x + dx);
      blue = blue || (p[0] > 150 && p[1] < 100 && p[2] < 100);
    }
    EXPECT_TRUE(blue) << amp << " um";
    // The note is drawn (dark pixels) in its line at the lower left, above the scale line.
    const cv::Mat line = img(cv::Rect(static_cast<int>(0.03 * size), static_cast<int>(0.92 * size),
                                      200, static_cast<int>(0.03 * size)));
    cv::Mat grey;
    cv::cvtColor(line, grey, cv::COLOR_BGR2GRAY);
    EXPECT_GT(cv::countNonZero(grey < 100), 20);
  }
  PolarPlotOptions bad;
  bad.divisions = -1;
  PolarPlotTrace t{"x", {0.0, 1.0}, {0.0, 0.0}, {0, 0, 0}};
  EXPECT_THROW(RenderPolarPlot({t}, std::nullopt, bad), km::InvalidInput);
}

TEST(PolarPlot, RejectsEmptyInput) {
  EXPECT_THROW(RenderPolarPlot({}, std::nullopt), km::InvalidInput);
}

}  // namespace
}  // namespace km::render
