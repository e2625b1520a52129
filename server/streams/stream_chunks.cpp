#include "server/streams/stream_chunks.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>

#include "analysis/core/errors.h"

namespace km::server {
namespace {

void PutVarint(std::string& out, std::uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<char>((v & 0x7f) | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<char>(v));
}

std::uint64_t ZigZag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
std::int64_t UnZigZag(std::uint64_t v) {
  return static_cast<std::int64_t>(v >> 1) ^ -static_cast<std::int64_t>(v & 1);
}

class Reader {
 public:
  explicit Reader(const std::string& s) : p_(s.data()), end_(s.data() + s.size()) {}
  std::uint64_t Varint() {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      if (p_ == end_) Damaged();
      const auto b = static_cast<unsigned char>(*p_++);
      v |= static_cast<std::uint64_t>(b & 0x7f) << shift;
      if (!(b & 0x80)) return v;
    }
    Damaged();
  }
  const char* Take(std::size_t n) {
    if (static_cast<std::size_t>(end_ - p_) < n) Damaged();
    const char* at = p_;
    p_ += n;
    return at;
  }
  bool AtEnd() const { return p_ == end_; }
  [[noreturn]] static void Damaged() { throw Error("stream chunk: stored data is damaged"); }

 private:
  const char* p_;
  const char* end_;
};

static_assert(std::endian::native == std::endian::little,
              "the chunk encoding copies little-endian doubles directly");

}  // namespace

StreamChunk EncodeStreamChunk(const ingest::SampleRun& run, std::size_t begin, std::size_t end) {
  StreamChunk c;
  const std::size_t n = end - begin;
  c.channel = run.channel;
  c.first_counter = static_cast<std::int64_t>(run.first_counter + begin);
  c.n = static_cast<std::int64_t>(n);
  c.t_first_us = run.t_us[begin];
  c.t_last_us = run.t_us[end - 1];
  c.value_min = std::numeric_limits<double>::infinity();
  c.value_max = -std::numeric_limits<double>::infinity();
  bool any_status = false;
  for (std::size_t i = begin; i < end; ++i) {
    const double v = run.value_um[i];
    c.value_min = std::min(c.value_min, v);
    c.value_max = std::max(c.value_max, v);
    c.value_sum += v;
    if (run.status[i] != ingest::kStatusGood) {
      ++c.flagged;
      any_status = true;
    }
    c.t_first_us = std::min(c.t_first_us, run.t_us[i]);
    c.t_last_us = std::max(c.t_last_us, run.t_us[i]);
  }
  std::string& out = c.data;
  out.reserve(8 + n * (any_status ? 11 : 10));
  out.push_back(1);
  out.push_back(any_status ? 1 : 0);
  PutVarint(out, n);
  std::int64_t prev = 0;
  for (std::size_t i = begin; i < end; ++i) {
    // Unsigned wrap-around keeps any int64 pair exact (decoded the same way).
    PutVarint(out, ZigZag(static_cast<std::int64_t>(static_cast<std::uint64_t>(run.t_us[i]) -
                                                    static_cast<std::uint64_t>(prev))));
    prev = run.t_us[i];
  }
  const std::size_t at = out.size();
  out.resize(at + n * sizeof(double));
  std::memcpy(out.data() + at, run.value_um.data() + begin, n * sizeof(double));
  if (any_status) {
    out.append(reinterpret_cast<const char*>(run.status.data() + begin), n);
  }
  return c;
}

ingest::SampleRun DecodeStreamChunk(const StreamChunk& chunk) {
  Reader r(chunk.data);
  const char* head = r.Take(2);
  if (head[0] != 1 || (head[1] & ~1) != 0) Reader::Damaged();
  const bool has_status = head[1] & 1;
  const std::uint64_t n = r.Varint();
  if (n != static_cast<std::uint64_t>(chunk.n) || n > chunk.data.size()) Reader::Damaged();
  ingest::SampleRun run;
  run.channel = static_cast<std::uint32_t>(chunk.channel);
  run.first_counter = static_cast<std::uint64_t>(chunk.first_counter);
  run.t_us.resize(n);
  run.value_um.resize(n);
  run.status.assign(n, ingest::kStatusGood);
  std::int64_t t = 0;
  for (std::uint64_t i = 0; i < n; ++i) {
    t = static_cast<std::int64_t>(static_cast<std::uint64_t>(t) +
                                  static_cast<std::uint64_t>(UnZigZag(r.Varint())));
    run.t_us[i] = t;
  }
  std::memcpy(run.value_um.data(), r.Take(n * sizeof(double)), n * sizeof(double));
  if (has_status) std::memcpy(run.status.data(), r.Take(n), n);
  if (!r.AtEnd()) Reader::Damaged();
  return run;
}

}  // namespace km::server
