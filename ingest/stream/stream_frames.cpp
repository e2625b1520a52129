#include "ingest/stream/stream_frames.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/crc32.h"
#include "ingest/json_text.h"
#include "ingest/stream/stream_frames_bytes.h"

namespace km::ingest {
namespace {

static_assert(std::endian::native == std::endian::little || std::endian::native == std::endian::big,
              "mixed-endian hosts are not supported");

constexpr std::size_t kMaxSamplesLimit = std::size_t{1} << 24;
constexpr std::size_t kLineBaseBytes = 4096;
constexpr std::size_t kLineBytesPerSample = 80;

using frame_bytes::LoadLe;
using frame_bytes::LoadLeDouble;
using frame_bytes::UniformTime;

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

bool IsBlank(std::string_view s) {
  return std::all_of(s.begin(), s.end(), [](char c) { return c == ' ' || c == '\t' || c == '\r'; });
}

using Json = nlohmann::json;

// Counters stop at kMaxStreamCounter and do not wrap (docs/streams.md).
std::string CounterRangeMessage(std::uint64_t first, std::uint64_t n) {
  return "counters " + std::to_string(first) + " … " + std::to_string(first) + " + " +
         std::to_string(n - 1) + " go beyond 9223372036854775807 (2^63 - 1), the largest " +
         "counter; counters do not wrap around: a device that restarts its count starts a " +
         "new stream";
}

}  // namespace

FrameFormat FrameFormatFromContentType(std::string_view content_type) {
  std::string_view type = content_type.substr(0, content_type.find(';'));
  while (!type.empty() && std::isspace(static_cast<unsigned char>(type.front())))
    type.remove_prefix(1);
  while (!type.empty() && std::isspace(static_cast<unsigned char>(type.back())))
    type.remove_suffix(1);
  const std::string lower = Lower(type);
  if (lower == kBinaryFrameContentType) return FrameFormat::kBinary;
  if (lower == kNdjsonContentType) return FrameFormat::kNdjson;
  throw InvalidInput("", 0, "Content-Type",
                     "unsupported stream type '" + std::string(content_type) + "' (use " +
                         std::string(kBinaryFrameContentType) + " or " +
                         std::string(kNdjsonContentType) + ")");
}

StreamFrameDecoder::StreamFrameDecoder(FrameFormat format, std::string source_name,
                                       std::size_t max_samples_per_frame)
    : format_(format), source_(std::move(source_name)), max_samples_(max_samples_per_frame) {
  if (max_samples_ == 0 || max_samples_ > kMaxSamplesLimit) {
    throw std::invalid_argument("StreamFrameDecoder: max_samples_per_frame must be 1 … 2^24");
  }
  max_line_bytes_ = kLineBaseBytes + kLineBytesPerSample * max_samples_;
}

void StreamFrameDecoder::CheckUsable() const {
  if (failed_) {
    throw InvalidInput(source_, 0, "", "stream decoding already stopped at an earlier error");
  }
  if (finished_) throw InvalidInput(source_, 0, "", "stream already finished");
}

void StreamFrameDecoder::Feed(std::string_view bytes, const RunCallback& on_run) {
  CheckUsable();
  bytes_ += bytes.size();
  try {
    if (format_ == FrameFormat::kBinary) {
      FeedBinary(bytes, on_run);
    } else {
      FeedNdjson(bytes, on_run);
    }
  } catch (...) {
    failed_ = true;
    pending_.clear();
    pending_.shrink_to_fit();
    throw;
  }
}

void StreamFrameDecoder::Finish() {
  Finish(nullptr);
}

void StreamFrameDecoder::Finish(const RunCallback& on_run) {
  CheckUsable();
  try {
    if (format_ == FrameFormat::kBinary) {
      if (!pending_.empty()) {
        CheckMagicPrefix(pending_.data(), pending_.size());
        const std::size_t expected = have_header_ ? header_.frame_bytes : kFrameHeaderBytes;
        FrameError(have_header_ ? "payload" : "header",
                   "truncated: stream ends after " + std::to_string(pending_.size()) + " of " +
                       std::to_string(expected) + (have_header_ ? " frame" : " header") + " bytes");
      }
    } else if (!pending_.empty() && !IsBlank(pending_)) {
      if (!on_run) {
        throw InvalidInput(source_, line_no_ + 1, "line",
                           "last line is not terminated by a newline (truncated upload?)");
      }
      std::string last;
      last.swap(pending_);
      ProcessLine(last, on_run);
    }
  } catch (...) {
    failed_ = true;
    throw;
  }
  pending_.clear();
  finished_ = true;
}

// ---------------------------------------------------------------------------------------------
// Binary frames

void StreamFrameDecoder::FrameError(const std::string& field, const std::string& reason) const {
  throw InvalidInput(source_, frames_ + 1, field,
                     "frame at byte offset " + std::to_string(consumed_) + ": " + reason);
}

void StreamFrameDecoder::CheckMagicPrefix(const char* p, std::size_t size) const {
  const std::size_t m = std::min<std::size_t>(size, 4);
  if (std::memcmp(p, "KMSF", m) != 0) FrameError("magic", "expected \"KMSF\"");
}

StreamFrameDecoder::Header StreamFrameDecoder::ParseHeader(const char* p) const {
  CheckMagicPrefix(p, 4);
  const auto version = static_cast<std::uint8_t>(p[4]);
  if (version != kFrameVersion) {
    FrameError("version", "unsupported version " + std::to_string(version) + " (expected 1)");
  }
  Header h;
  h.flags = static_cast<std::uint8_t>(p[5]);
  if ((h.flags & ~(kFrameFlagStatus | kFrameFlagTimestamps)) != 0) {
    FrameError("flags", "unknown flag bits set (flags = " + std::to_string(h.flags) +
                            "; only bit 0 and bit 1 are defined)");
  }
  h.channel = LoadLe<std::uint16_t>(p + 6);
  h.n = LoadLe<std::uint32_t>(p + 8);
  h.first_counter = LoadLe<std::uint64_t>(p + 12);
  h.t0_us = LoadLe<std::int64_t>(p + 20);
  h.dt_ns = LoadLe<std::uint32_t>(p + 28);
  if (h.n == 0 || h.n > kFrameMaxSamples) {
    FrameError("n", "sample count " + std::to_string(h.n) + " outside 1 … 65536");
  }
  if (h.n > max_samples_) {
    throw TooLarge(source_, frames_ + 1, "n",
                   "frame at byte offset " + std::to_string(consumed_) + ": " +
                       std::to_string(h.n) + " samples exceed the limit of " +
                       std::to_string(max_samples_) + " per frame");
  }
  if (h.first_counter > kMaxStreamCounter - (h.n - 1)) {
    FrameError("first_counter", CounterRangeMessage(h.first_counter, h.n));
  }
  const bool with_times = (h.flags & kFrameFlagTimestamps) != 0;
  if (!with_times) {
    if (h.dt_ns == 0) FrameError("dt_ns", "sample period must be > 0 without per-sample t_us");
    std::int64_t t_last = 0;
    if (!UniformTime(h.t0_us, h.n - 1, h.dt_ns, &t_last)) {
      FrameError("t0_us", "timestamps overflow int64 within the frame");
    }
  }
  h.frame_bytes = kFrameHeaderBytes + std::size_t{h.n} * 8 +
                  (with_times ? std::size_t{h.n} * 8 : 0) +
                  ((h.flags & kFrameFlagStatus) != 0 ? std::size_t{h.n} : 0) + 4;
  return h;
}

void StreamFrameDecoder::DecodeFrame(const char* p, const Header& h, const RunCallback& on_run) {
  const std::size_t crc_at = h.frame_bytes - 4;
  const std::uint32_t stored = LoadLe<std::uint32_t>(p + crc_at);
  const std::uint32_t computed = Crc32Update(0, p, crc_at);
  if (stored != computed) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "CRC-32 mismatch (stored 0x%08X, computed 0x%08X)", stored,
                  computed);
    FrameError("crc32", buf);
  }
  SampleRun run;
  run.channel = h.channel;
  run.first_counter = h.first_counter;
  run.value_um.resize(h.n);
  run.t_us.resize(h.n);
  const char* q = p + kFrameHeaderBytes;
  for (std::uint32_t k = 0; k < h.n; ++k, q += 8) {
    const double v = LoadLeDouble(q);
    if (!std::isfinite(v)) {
      FrameError("value_um", "sample " + std::to_string(k) + " is not a finite number");
    }
    run.value_um[k] = v;
  }
  if ((h.flags & kFrameFlagTimestamps) != 0) {
    for (std::uint32_t k = 0; k < h.n; ++k, q += 8) run.t_us[k] = LoadLe<std::int64_t>(q);
    if (run.t_us[0] != h.t0_us) {
      FrameError("t0_us", "t0_us " + std::to_string(h.t0_us) + " differs from t_us[0] " +
                              std::to_string(run.t_us[0]));
    }
  } else {
    for (std::uint32_t k = 0; k < h.n; ++k) {
      UniformTime(h.t0_us, k, h.dt_ns,
                  &run.t_us[k]);  // overflow excluded by ParseHeader
    }
  }
  if ((h.flags & kFrameFlagStatus) != 0) {
    run.status.assign(reinterpret_cast<const std::uint8_t*>(q),
                      reinterpret_cast<const std::uint8_t*>(q) + h.n);
  } else {
    run.status.assign(h.n, kStatusGood);
  }
  ++frames_;
  samples_ += h.n;
  consumed_ += h.frame_bytes;
  on_run(std::move(run));
}

void StreamFrameDecoder::FeedBinary(std::string_view bytes, const RunCallback& on_run) {
  const char* p = bytes.data();
  std::size_t left = bytes.size();
  while (left > 0) {
    if (pending_.empty()) {
      // Whole frames straight from the caller's buffer, without copying.
      if (left < kFrameHeaderBytes) {
        CheckMagicPrefix(p, left);
        pending_.assign(p, left);
        return;
      }
      const Header h = ParseHeader(p);
      if (left < h.frame_bytes) {
        pending_.reserve(h.frame_bytes);
        pending_.assign(p, left);
        header_ = h;
        have_header_ = true;
        return;
      }
      DecodeFrame(p, h, on_run);
      p += h.frame_bytes;
      left -= h.frame_bytes;
      continue;
    }
    // Completing a frame split across calls: take only what this frame still
    // needs.
    const std::size_t need = have_header_ ? header_.frame_bytes : kFrameHeaderBytes;
    const std::size_t take = std::min(need - pending_.size(), left);
    pending_.append(p, take);
    p += take;
    left -= take;
    if (!have_header_) {
      if (pending_.size() < kFrameHeaderBytes) {
        CheckMagicPrefix(pending_.data(), pending_.size());
        return;
      }
      header_ = ParseHeader(pending_.data());
      have_header_ = true;
      pending_.reserve(header_.frame_bytes);
    }
    if (pending_.size() == header_.frame_bytes) {
      DecodeFrame(pending_.data(), header_, on_run);
      pending_.clear();
      have_header_ = false;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// NDJSON

namespace {

class LineContext {
 public:
  LineContext(const std::string& source, std::size_t line) : source_(source), line_(line) {}

  [[noreturn]] void Fail(const std::string& field, const std::string& reason) const {
    throw InvalidInput(source_, line_, field, reason);
  }

  std::uint64_t Unsigned(const Json& v, const std::string& field, std::uint64_t max,
                         const std::string& where = "") const {
    if (v.is_number_unsigned()) {
      const auto x = v.get<std::uint64_t>();
      if (x > max)
        Fail(field, where + "value " + std::to_string(x) + " exceeds " + std::to_string(max));
      return x;
    }
    if (v.is_number_integer()) {
      if (v.get<std::int64_t>() == 0) return 0;  // "-0"
      Fail(field, where + "must be ≥ 0");
    }
    Fail(field, where + "must be a non-negative integer");
  }

  std::int64_t Signed(const Json& v, const std::string& field,
                      const std::string& where = "") const {
    if (v.is_number_unsigned()) {
      const auto x = v.get<std::uint64_t>();
      if (x > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
        Fail(field, where + "integer out of the int64 range");
      }
      return static_cast<std::int64_t>(x);
    }
    if (v.is_number_integer()) return v.get<std::int64_t>();
    Fail(field, where + "must be an integer (µs)");
  }

  double Finite(const Json& v, const std::string& field, const std::string& where = "") const {
    if (!v.is_number()) Fail(field, where + "must be a number");
    const double x = v.get<double>();
    if (!std::isfinite(x)) Fail(field, where + "must be finite");
    return x;
  }

  const Json& Array(const Json& obj, const std::string& field) const {
    const Json& a = obj.at(field);
    if (!a.is_array()) Fail(field, "must be an array");
    return a;
  }

 private:
  const std::string& source_;
  std::size_t line_;
};

std::string Element(std::size_t k) {
  return "element " + std::to_string(k) + ": ";
}

// The timestamps of a run line of n samples: a t_us array, or t0_us and dt_us (µs), each
// checked against int64 overflow.
void RunTimes(const LineContext& ctx, const Json& obj, std::size_t n,
              std::vector<std::int64_t>& t_us) {
  const bool has_t = obj.contains("t_us");
  const bool has_t0 = obj.contains("t0_us");
  const bool has_dt = obj.contains("dt_us");
  t_us.resize(n);
  if (has_t) {
    if (has_t0 || has_dt) {
      ctx.Fail(has_t0 ? "t0_us" : "dt_us", "give either a t_us array or t0_us and dt_us, not both");
    }
    const Json& times = ctx.Array(obj, "t_us");
    if (times.size() != n) {
      ctx.Fail("t_us", "has " + std::to_string(times.size()) + " elements, values_um has " +
                           std::to_string(n));
    }
    for (std::size_t k = 0; k < n; ++k) t_us[k] = ctx.Signed(times[k], "t_us", Element(k));
  } else {
    if (!has_t0) ctx.Fail("t0_us", "missing (give t0_us and dt_us, or a t_us array)");
    if (!has_dt) ctx.Fail("dt_us", "missing (give t0_us and dt_us, or a t_us array)");
    const std::int64_t t0 = ctx.Signed(obj.at("t0_us"), "t0_us");
    const double dt = ctx.Finite(obj.at("dt_us"), "dt_us");
    if (!(dt > 0)) ctx.Fail("dt_us", "sample period must be > 0");
    // Largest offset first: if it fits, all do.
    const double last = static_cast<double>(n - 1) * dt;
    if (last >= 9.0e18) ctx.Fail("dt_us", "timestamps overflow int64 within the run");
    for (std::size_t k = 0; k < n; ++k) {
      const long long off = std::llround(static_cast<double>(k) * dt);
      if (__builtin_add_overflow(t0, static_cast<std::int64_t>(off), &t_us[k])) {
        ctx.Fail("t0_us", "timestamps overflow int64 within the run");
      }
    }
  }
}

}  // namespace

void StreamFrameDecoder::FeedNdjson(std::string_view bytes, const RunCallback& on_run) {
  while (!bytes.empty()) {
    const std::size_t nl = bytes.find('\n');
    const std::size_t len = nl == std::string_view::npos ? bytes.size() : nl;
    if (pending_.size() + len > max_line_bytes_) {
      throw TooLarge(source_, line_no_ + 1, "line",
                     "line longer than " + std::to_string(max_line_bytes_) + " bytes");
    }
    if (nl == std::string_view::npos) {
      pending_.append(bytes);
      return;
    }
    if (pending_.empty()) {
      ProcessLine(bytes.substr(0, len), on_run);
    } else {
      pending_.append(bytes.substr(0, len));
      std::string line;
      line.swap(pending_);
      ProcessLine(line, on_run);
    }
    bytes.remove_prefix(len + 1);
  }
}

void StreamFrameDecoder::ProcessLine(std::string_view line, const RunCallback& on_run) {
  ++line_no_;
  if (IsBlank(line)) return;
  const LineContext ctx(source_, line_no_);
  // A repeated key (e.g. a pasted "t_us" that would silently replace the first) is refused by
  // the parser, as is nesting deeper than a line's arrays.
  Json obj;
  try {
    obj = ParseJsonText(line, source_, JsonTextLimits{.max_depth = 2});
  } catch (const InvalidInput& e) {
    // A syntax error is the line's ("json"); a refused value names its key in the line.
    const bool syntax = e.reason().rfind("not valid JSON", 0) == 0;
    const std::string key = e.field().substr(0, e.field().find_first_of("[."));
    ctx.Fail(syntax || key.empty() ? std::string("json") : key, e.reason());
  }
  if (!obj.is_object()) ctx.Fail("json", "each line must be one JSON object");

  const bool is_run = obj.contains("values_um");
  static const char* const kSampleKeys[] = {"channel", "counter", "t_us", "value_um", "status"};
  static const char* const kRunKeys[] = {"channel", "first_counter", "t0_us", "dt_us",
                                         "t_us",    "values_um",     "status"};
  for (const auto& item : obj.items()) {
    const auto& key = item.key();
    const bool known = is_run ? std::any_of(std::begin(kRunKeys), std::end(kRunKeys),
                                            [&](const char* k) { return key == k; })
                              : std::any_of(std::begin(kSampleKeys), std::end(kSampleKeys),
                                            [&](const char* k) { return key == k; });
    if (!known) {
      // The key names the field (shortened: it is echoed into messages); "" cannot.
      ctx.Fail(key.empty() ? std::string("json") : key.substr(0, 64),
               is_run ? "unknown key in a run line (allowed: channel, "
                        "first_counter, t0_us, "
                        "dt_us, t_us, values_um, status)"
                      : "unknown key in a sample line (allowed: channel, "
                        "counter, t_us, "
                        "value_um, status)");
    }
  }
  auto require = [&](const char* key) -> const Json& {
    const auto it = obj.find(key);
    if (it == obj.end()) ctx.Fail(key, "missing");
    return *it;
  };

  SampleRun run;
  run.channel = static_cast<std::uint32_t>(ctx.Unsigned(require("channel"), "channel", 65535));
  if (!is_run) {
    run.first_counter = ctx.Unsigned(require("counter"), "counter", kMaxStreamCounter);
    run.t_us.push_back(ctx.Signed(require("t_us"), "t_us"));
    run.value_um.push_back(ctx.Finite(require("value_um"), "value_um"));
    const auto st = obj.find("status");
    run.status.push_back(st == obj.end()
                             ? kStatusGood
                             : static_cast<std::uint8_t>(ctx.Unsigned(*st, "status", 255)));
  } else {
    run.first_counter = ctx.Unsigned(require("first_counter"), "first_counter", kMaxStreamCounter);
    const Json& values = ctx.Array(obj, "values_um");
    const std::size_t n = values.size();
    if (n == 0) ctx.Fail("values_um", "must not be empty");
    if (n > max_samples_) {
      throw TooLarge(source_, line_no_, "values_um",
                     std::to_string(n) + " samples exceed the limit of " +
                         std::to_string(max_samples_) + " per run");
    }
    if (run.first_counter > kMaxStreamCounter - (n - 1)) {
      ctx.Fail("first_counter", CounterRangeMessage(run.first_counter, n));
    }
    run.value_um.resize(n);
    for (std::size_t k = 0; k < n; ++k)
      run.value_um[k] = ctx.Finite(values[k], "values_um", Element(k));

    RunTimes(ctx, obj, n, run.t_us);
    run.status.assign(n, kStatusGood);
    const auto st = obj.find("status");
    if (st != obj.end()) {
      if (!st->is_array()) ctx.Fail("status", "must be an array in a run line");
      if (st->size() != n) {
        ctx.Fail("status", "has " + std::to_string(st->size()) + " elements, values_um has " +
                               std::to_string(n));
      }
      for (std::size_t k = 0; k < n; ++k) {
        run.status[k] =
            static_cast<std::uint8_t>(ctx.Unsigned((*st)[k], "status", 255, Element(k)));
      }
    }
  }
  ++frames_;
  samples_ += run.size();
  on_run(std::move(run));
}

}  // namespace km::ingest
