// CRC-32 as used by IEEE 802.3, zlib, PNG and gzip: the reflected polynomial
// 0xEDB88320 (x^32 + x^26 + x^23 + x^22 + x^16 + x^12 + x^11 + x^10 + x^8 + x^7
// + x^5 + x^4 + x^2 + x + 1), register initialised to 0xFFFFFFFF and the result
// complemented (xorout 0xFFFFFFFF). Check value: Crc32("123456789") ==
// 0xCBF43926.
//
// The computation is table driven, slicing-by-8: eight 256-entry tables T_j,
// where T_0 is the classic byte table and T_j[b] = (T_{j-1}[b] >> 8) ^
// T_0[T_{j-1}[b] & 0xFF], so that eight input bytes are folded into the
// register with eight independent look-ups.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace km::ingest {

// zlib-style running CRC: Crc32Update(0, a) followed by Crc32Update(that, b)
// equals Crc32(a + b).
std::uint32_t Crc32Update(std::uint32_t crc, const void* data, std::size_t size);

inline std::uint32_t Crc32(std::string_view data) {
  return Crc32Update(0, data.data(), data.size());
}

// Plain bit-at-a-time reference implementation (slow); used by tests as an
// independent check.
std::uint32_t Crc32Bitwise(std::string_view data);

}  // namespace km::ingest
