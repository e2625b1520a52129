// PNG encoding of an 8-bit, 3-channel image (the polar plots): one IDAT chunk of the zlib
// stream of the rows, each with the "Sub" filter (a plot is mostly flat colour, which the
// filter turns into runs of zeros). Written here so that drawing a plot needs OpenCV's core
// and drawing functions only, not its image-file codecs and their libraries.
#pragma once

#include <cstddef>
#include <vector>

namespace km::render {

// `bgr`: rows of width × 3 bytes in blue, green, red order, `stride` bytes apart. Throws
// km::InvalidInput for an empty image or a failure of the compressor.
std::vector<unsigned char> EncodePngBgr(const unsigned char* bgr, int width, int height,
                                        std::size_t stride);

}  // namespace km::render
