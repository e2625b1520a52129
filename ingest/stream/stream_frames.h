// Wire formats of capacitance-sensor HTTP streams (docs/formats.md §1.6; user
// documentation in docs/streams.md, "Frame formats") and their incremental
// decoder / encoder.
//
// 1. Binary frames, Content-Type application/vnd.kinemetric.stream-frame, back
// to back:
//      "KMSF" | u8 version=1 | u8 flags | u16 channel | u32 n | u64
//      first_counter | i64 t0_us | u32 dt_ns | n × f64 value_um | [flags bit1]
//      n × i64 t_us | [flags bit0] n × u8 status | u32 CRC-32 (IEEE, see
//      crc32.h) of everything before it.               (little-endian)
//    Without per-sample timestamps, sample k (k = 0 … n−1) is at
//      t_k = t0_us + (k·dt_ns + 500) / 1000        (integer division: nearest
//      µs, ties up)
//    so a uniformly sampled stream needs no per-sample times; counters are
//    first_counter + k.
// 2. NDJSON, Content-Type application/x-ndjson: one JSON object per line,
// either one sample
//      {"channel","counter","t_us","value_um"[,"status"]}
//    or a run of consecutive counters
//      {"channel","first_counter","values_um":[…][,"status":[…]]} plus either
//      "t_us":[…] or "t0_us" and "dt_us", with t_k = t0_us + llround(k·dt_us)
//      (dt_us may be fractional).
//
// The decoder is incremental: bytes may be fed in pieces split anywhere; each
// complete frame or line is delivered as one SampleRun before Feed returns.
// Memory is bounded: a binary frame is validated from its 32-byte header before
// any of its payload is buffered, and an NDJSON line longer than 4 KiB + 80
// bytes per allowed sample is refused.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "ingest/stream/stream_record.h"

namespace km::ingest {

enum class FrameFormat { kBinary, kNdjson };

inline constexpr std::string_view kBinaryFrameContentType =
    "application/vnd.kinemetric.stream-frame";
inline constexpr std::string_view kNdjsonContentType = "application/x-ndjson";

inline constexpr std::uint8_t kFrameVersion = 1;
inline constexpr std::uint8_t kFrameFlagStatus = 0x01;      // per-sample status bytes present
inline constexpr std::uint8_t kFrameFlagTimestamps = 0x02;  // per-sample i64 t_us present
inline constexpr std::size_t kFrameHeaderBytes = 32;
inline constexpr std::size_t kFrameMaxSamples = 65536;

// Media type (parameters such as "; charset=utf-8" and letter case ignored) to
// format. Throws km::InvalidInput (field "Content-Type") for any other type.
FrameFormat FrameFormatFromContentType(std::string_view content_type);

class StreamFrameDecoder {
 public:
  using RunCallback = std::function<void(SampleRun&&)>;

  // max_samples_per_frame (1 … 16777216; binary frames cannot exceed 65536
  // anyway) bounds one frame / one NDJSON run; a larger one is refused with
  // km::TooLarge. Throws std::invalid_argument for a limit outside that range.
  StreamFrameDecoder(FrameFormat format, std::string source_name,
                     std::size_t max_samples_per_frame = kFrameMaxSamples);

  // Feeds bytes; for each complete frame / line calls on_run before returning.
  // Throws km::InvalidInput(source_name, N, field, reason) on a bad frame (N =
  // 1-based frame number, the reason names its byte offset) or line (N = line
  // number); frames before it were already delivered. After any throw (also one
  // from on_run) the decoder refuses further input.
  void Feed(std::string_view bytes, const RunCallback& on_run);
  // End of input. Throws km::InvalidInput when an incomplete frame remains
  // (truncated upload). An NDJSON last line without '\n' is accepted when it is
  // a complete valid line; on_run is called for it.
  void Finish(const RunCallback& on_run);
  void Finish();  // same; a pending unterminated last NDJSON line is an error here

  FrameFormat format() const { return format_; }
  std::uint64_t frames() const { return frames_; }    // frames / non-blank lines delivered
  std::uint64_t samples() const { return samples_; }  // samples delivered
  std::uint64_t bytes() const { return bytes_; }      // bytes fed

 private:
  struct Header {
    std::uint8_t flags = 0;
    std::uint32_t channel = 0;
    std::uint32_t n = 0;
    std::uint64_t first_counter = 0;
    std::int64_t t0_us = 0;
    std::uint32_t dt_ns = 0;
    std::size_t frame_bytes = 0;
  };

  void FeedBinary(std::string_view bytes, const RunCallback& on_run);
  void FeedNdjson(std::string_view bytes, const RunCallback& on_run);
  void CheckMagicPrefix(const char* p, std::size_t size) const;
  Header ParseHeader(const char* p) const;
  void DecodeFrame(const char* p, const Header& h, const RunCallback& on_run);
  void ProcessLine(std::string_view line, const RunCallback& on_run);
  [[noreturn]] void FrameError(const std::string& field, const std::string& reason) const;
  void CheckUsable() const;

  FrameFormat format_;
  std::string source_;
  std::size_t max_samples_;
  std::size_t max_line_bytes_;
  std::string pending_;
  bool have_header_ = false;
  Header header_;
  bool failed_ = false;
  bool finished_ = false;
  std::uint64_t consumed_ = 0;  // binary: byte offset of the frame being assembled
  std::uint64_t line_no_ = 0;   // NDJSON: lines completed so far
  std::uint64_t frames_ = 0;
  std::uint64_t samples_ = 0;
  std::uint64_t bytes_ = 0;
};

// Encodes one binary frame. with_timestamps: per-sample t_us are written (dt_ns
// is written as given and ignored by decoders); otherwise t0_us = run.t_us[0]
// and every run.t_us[k] must equal t0_us + (k·dt_ns + 500)/1000 exactly, dt_ns
// > 0. with_status: per-sample status bytes are written; otherwise every status
// must be 0 (an empty status vector means all 0). Throws std::invalid_argument
// for a run that the format cannot carry (size 0 or > 65536, channel > 65535,
// lengths differ, non-finite values, counter overflow, the timing check above).
std::string EncodeBinaryFrame(const SampleRun& run, bool with_timestamps, bool with_status,
                              std::uint32_t dt_ns);

// One NDJSON run line in the "t_us" array form, '\n'-terminated; "status" only
// when some status is non-zero. Doubles are written in the shortest form that
// reads back bit-exactly. Throws std::invalid_argument as EncodeBinaryFrame
// does (no size limit of 65536 here).
std::string EncodeNdjsonRun(const SampleRun& run);
// One NDJSON single-sample line, '\n'-terminated.
std::string EncodeNdjsonSample(const StreamSample& sample);

}  // namespace km::ingest
