// The PNG encoder of the polar plots, decoded by an independent decoder (OpenCV's, libpng):
// every pixel comes back exactly, for images whose rows are padded and whose colours change
// across the whole byte range (the Sub filter wraps around).
#include "render/png.h"

#include <cstdint>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "analysis/core/errors.h"

namespace km::render {
namespace {

void ExpectRoundTrip(int width, int height, std::size_t pad) {
  const std::size_t stride = static_cast<std::size_t>(width) * 3 + pad;
  std::vector<unsigned char> bgr(stride * static_cast<std::size_t>(height), 0xEE);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c)
        bgr[static_cast<std::size_t>(y) * stride + static_cast<std::size_t>(x) * 3 +
            static_cast<std::size_t>(c)] =
            static_cast<unsigned char>((x * 37 + y * 11 + c * 101) ^ (x * y));
  const std::vector<unsigned char> png = EncodePngBgr(bgr.data(), width, height, stride);
  const cv::Mat img = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(img.cols, width);
  ASSERT_EQ(img.rows, height);
  ASSERT_EQ(img.type(), CV_8UC3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(img.at<cv::Vec3b>(y, x)[c],
                  bgr[static_cast<std::size_t>(y) * stride + static_cast<std::size_t>(x) * 3 +
                      static_cast<std::size_t>(c)])
            << x << "," << y << "," << c;
}

TEST(PngEncoder, EveryPixelDecodesExactly) {
  ExpectRoundTrip(1, 1, 0);
  ExpectRoundTrip(97, 41, 0);
  ExpectRoundTrip(64, 300, 5);
}

TEST(PngEncoder, FlatImageCompresses) {
  std::vector<unsigned char> white(800 * 800 * 3, 255);
  const auto png = EncodePngBgr(white.data(), 800, 800, 800 * 3);
  EXPECT_LT(png.size(), 5000u);
  const cv::Mat img = cv::imdecode(png, cv::IMREAD_COLOR);
  ASSERT_EQ(img.cols, 800);
  EXPECT_EQ(cv::countNonZero(img.reshape(1) != 255), 0);
}

TEST(PngEncoder, EmptyImageIsRefused) {
  unsigned char px[3] = {0, 0, 0};
  EXPECT_THROW(EncodePngBgr(px, 0, 1, 3), InvalidInput);
  EXPECT_THROW(EncodePngBgr(nullptr, 1, 1, 3), InvalidInput);
}

}  // namespace
}  // namespace km::render
