// Compact sample blob: "KMS1", u32 column count, u64 row count, each column name as u32 length +
// bytes, then the values as little-endian IEEE-754 doubles, row-major.
#include <bit>
#include <cstdint>
#include <cstring>

#include "analysis/core/errors.h"
#include "server/storage/storage.h"

namespace km::server {
namespace {

static_assert(std::endian::native == std::endian::little, "the sample blob is little-endian");

template <typename T>
void Put(std::string& out, T v) {
  char buf[sizeof(T)];
  std::memcpy(buf, &v, sizeof(T));
  out.append(buf, sizeof(T));
}

template <typename T>
T Get(const std::string& in, std::size_t& pos) {
  if (pos + sizeof(T) > in.size()) throw Error("sample blob is truncated");
  T v;
  std::memcpy(&v, in.data() + pos, sizeof(T));
  pos += sizeof(T);
  return v;
}

}  // namespace

std::vector<double> SampleBlock::Column(std::size_t c) const {
  std::vector<double> out;
  const std::size_t n = columns.size();
  if (c >= n) return out;
  out.reserve(rows());
  for (std::size_t i = c; i < values.size(); i += n) out.push_back(values[i]);
  return out;
}

std::string EncodeSamples(const SampleBlock& block) {
  std::string out = "KMS1";
  Put<std::uint32_t>(out, static_cast<std::uint32_t>(block.columns.size()));
  Put<std::uint64_t>(out, block.rows());
  for (const auto& c : block.columns) {
    Put<std::uint32_t>(out, static_cast<std::uint32_t>(c.size()));
    out += c;
  }
  const std::size_t bytes = block.rows() * block.columns.size() * sizeof(double);
  const std::size_t at = out.size();
  out.resize(at + bytes);
  if (bytes) std::memcpy(out.data() + at, block.values.data(), bytes);
  return out;
}

SampleBlock DecodeSamples(const std::string& blob) {
  if (blob.compare(0, 4, "KMS1") != 0) throw Error("sample blob has an unknown layout");
  std::size_t pos = 4;
  SampleBlock b;
  const auto ncols = Get<std::uint32_t>(blob, pos);
  const auto nrows = Get<std::uint64_t>(blob, pos);
  for (std::uint32_t i = 0; i < ncols; ++i) {
    const auto len = Get<std::uint32_t>(blob, pos);
    if (pos + len > blob.size()) throw Error("sample blob is truncated");
    b.columns.push_back(blob.substr(pos, len));
    pos += len;
  }
  const std::size_t count = static_cast<std::size_t>(nrows) * ncols;
  if (blob.size() - pos != count * sizeof(double)) throw Error("sample blob has a wrong size");
  b.values.resize(count);
  if (count) std::memcpy(b.values.data(), blob.data() + pos, count * sizeof(double));
  return b;
}

}  // namespace km::server
