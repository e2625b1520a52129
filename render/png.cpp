#include "render/png.h"

#include <cstdint>
#include <string>

#include <zlib.h>

#include "analysis/core/errors.h"

namespace km::render {
namespace {

void PutU32(std::vector<unsigned char>& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<unsigned char>(v >> s));
}

// Length, type, data and the CRC of type and data (PNG specification §5.3).
void PutChunk(std::vector<unsigned char>& out, const char* type,
              const std::vector<unsigned char>& data) {
  PutU32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  uLong crc = crc32(0L, Z_NULL, 0);
  crc = crc32(crc, out.data() + start, static_cast<uInt>(out.size() - start));
  PutU32(out, static_cast<std::uint32_t>(crc));
}

// Rows in RGB order, each preceded by filter type 1 (Sub: the difference to the byte three to
// the left).
std::vector<unsigned char> FilteredRows(const unsigned char* bgr, int width, int height,
                                        std::size_t stride) {
  const std::size_t row = static_cast<std::size_t>(width) * 3;
  std::vector<unsigned char> raw((row + 1) * static_cast<std::size_t>(height));
  std::vector<unsigned char> rgb(row);
  for (int y = 0; y < height; ++y) {
    const unsigned char* src = bgr + static_cast<std::size_t>(y) * stride;
    for (std::size_t x = 0; x < row; x += 3) {
      rgb[x] = src[x + 2];
      rgb[x + 1] = src[x + 1];
      rgb[x + 2] = src[x];
    }
    unsigned char* dst = raw.data() + static_cast<std::size_t>(y) * (row + 1);
    dst[0] = 1;
    for (std::size_t x = 0; x < row; ++x)
      dst[1 + x] = static_cast<unsigned char>(rgb[x] - (x >= 3 ? rgb[x - 3] : 0));
  }
  return raw;
}

}  // namespace

std::vector<unsigned char> EncodePngBgr(const unsigned char* bgr, int width, int height,
                                        std::size_t stride) {
  if (width <= 0 || height <= 0 || bgr == nullptr) {
    throw InvalidInput("", 0, "plot", "empty image");
  }
  const std::vector<unsigned char> raw = FilteredRows(bgr, width, height, stride);
  uLongf zsize = compressBound(static_cast<uLong>(raw.size()));
  std::vector<unsigned char> z(zsize);
  if (compress2(z.data(), &zsize, raw.data(), static_cast<uLong>(raw.size()), 6) != Z_OK) {
    throw InvalidInput("", 0, "plot", "PNG compression failed");
  }
  z.resize(zsize);
  std::vector<unsigned char> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<unsigned char> ihdr;
  PutU32(ihdr, static_cast<std::uint32_t>(width));
  PutU32(ihdr, static_cast<std::uint32_t>(height));
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8 bits, truecolour, deflate, filters, no interlace
  PutChunk(png, "IHDR", ihdr);
  PutChunk(png, "IDAT", z);
  PutChunk(png, "IEND", {});
  return png;
}

}  // namespace km::render
