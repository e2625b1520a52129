// The capacitance-sensor stream record (docs/formats.md §1.6). HTTP stream frames and Modbus TCP
// acquisition both produce it, so storage, gap detection and analysis see one shape:
//
//   channel   — channel id, unique within a stream (a Modbus register map names its channels)
//   counter   — sample counter of that channel; consecutive samples differ by exactly 1, so a
//               jump in the counter is a gap (lost frame, missed poll) and is recorded as one
//   t_us      — acquisition time, µs since the Unix epoch (UTC)
//   value_um  — the reading in µm (after the device's scale and offset)
//   status    — 0 = good; non-zero values are sensor/acquisition flags, kept as given
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace km::ingest {

struct StreamSample {
  std::uint32_t channel = 0;
  std::uint64_t counter = 0;
  std::int64_t t_us = 0;
  double value_um = 0.0;
  std::uint8_t status = 0;
};

// Counters are 0 … 2⁶³ − 1 (docs/streams.md): they fit storage's signed 64-bit integers, and one
// past the last (the next expected counter) still fits an unsigned one. They do not wrap around.
inline constexpr std::uint64_t kMaxStreamCounter = 9223372036854775807ULL;  // 2⁶³ − 1

// Status values the product itself sets (devices may use others).
inline constexpr std::uint8_t kStatusGood = 0;

// A run of consecutive samples of one channel: counters first_counter, first_counter+1, …
// This is the unit in which frames arrive and in which storage keeps samples.
struct SampleRun {
  std::uint32_t channel = 0;
  std::uint64_t first_counter = 0;
  std::vector<std::int64_t> t_us;
  std::vector<double> value_um;
  std::vector<std::uint8_t> status;

  std::size_t size() const { return value_um.size(); }
};

// Where acquisition delivers samples. Implemented by the server (chunked storage, gap
// detection); ingest/ never includes server/. Called from acquisition threads: an
// implementation must be thread-safe.
class SampleSink {
 public:
  virtual ~SampleSink() = default;
  // One coherent set of readings taken at the same time (one Modbus block read, or one frame).
  virtual void Deliver(const std::vector<StreamSample>& samples) = 0;
};

}  // namespace km::ingest
