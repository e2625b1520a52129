// Internal to stream_frames*.cpp: little-endian loads and stores and the uniform time of a
// sample, shared by the frame decoder and the encoders.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <string>

namespace km::ingest::frame_bytes {

// Byte order reversal (std::byteswap is C++23).
template <typename T>
T ByteSwap(T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  std::reverse(b, b + sizeof(T));
  std::memcpy(&v, b, sizeof(T));
  return v;
}

template <typename T>
T LoadLe(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) v = ByteSwap(v);
  return v;
}

template <typename T>
void AppendLe(std::string& out, T v) {
  if constexpr (std::endian::native == std::endian::big) v = ByteSwap(v);
  char buf[sizeof(T)];
  std::memcpy(buf, &v, sizeof(T));
  out.append(buf, sizeof(T));
}

inline double LoadLeDouble(const char* p) {
  return std::bit_cast<double>(LoadLe<std::uint64_t>(p));
}

// t_k = t0 + (k·dt_ns + 500) / 1000; false on overflow of int64.
inline bool UniformTime(std::int64_t t0_us, std::uint64_t k, std::uint32_t dt_ns, std::int64_t* t) {
  // k < 2^24, dt_ns < 2^32: the product stays below 2^56.
  const auto offset = static_cast<std::int64_t>((k * dt_ns + 500) / 1000);
  return !__builtin_add_overflow(t0_us, offset, t);
}

}  // namespace km::ingest::frame_bytes
