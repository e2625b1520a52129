// Encoders of stream frames (ingest/stream/stream_frames.h): binary frames and NDJSON lines.
#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "ingest/crc32.h"
#include "ingest/stream/stream_frames.h"
#include "ingest/stream/stream_frames_bytes.h"

namespace km::ingest {

using frame_bytes::AppendLe;
using frame_bytes::UniformTime;

namespace {

void CheckRun(const SampleRun& run, std::size_t max_n) {
  const std::size_t n = run.value_um.size();
  if (n == 0 || n > max_n) {
    throw std::invalid_argument("stream frame: run of " + std::to_string(n) +
                                " samples (must be 1 … " + std::to_string(max_n) + ")");
  }
  if (run.channel > 65535) throw std::invalid_argument("stream frame: channel > 65535");
  if (run.t_us.size() != n)
    throw std::invalid_argument("stream frame: t_us and value_um differ in length");
  if (!run.status.empty() && run.status.size() != n) {
    throw std::invalid_argument("stream frame: status and value_um differ in length");
  }
  if (run.first_counter > std::numeric_limits<std::uint64_t>::max() - (n - 1)) {
    throw std::invalid_argument("stream frame: counter overflows 2^64");
  }
  for (const double v : run.value_um) {
    if (!std::isfinite(v)) throw std::invalid_argument("stream frame: value_um not finite");
  }
}

bool AnyStatus(const SampleRun& run) {
  return std::any_of(run.status.begin(), run.status.end(), [](std::uint8_t s) { return s != 0; });
}

}  // namespace

std::string EncodeBinaryFrame(const SampleRun& run, bool with_timestamps, bool with_status,
                              std::uint32_t dt_ns) {
  CheckRun(run, kFrameMaxSamples);
  const std::size_t n = run.size();
  if (!with_status && AnyStatus(run)) {
    throw std::invalid_argument("stream frame: non-zero status needs with_status");
  }
  if (!with_timestamps) {
    if (dt_ns == 0) throw std::invalid_argument("stream frame: dt_ns must be > 0");
    for (std::size_t k = 0; k < n; ++k) {
      std::int64_t t = 0;
      if (!UniformTime(run.t_us[0], k, dt_ns, &t) || t != run.t_us[k]) {
        throw std::invalid_argument("stream frame: t_us[" + std::to_string(k) +
                                    "] does not equal t0_us + (k·dt_ns + 500)/1000");
      }
    }
  }
  std::string out;
  out.reserve(kFrameHeaderBytes + n * (8 + (with_timestamps ? 8 : 0) + (with_status ? 1 : 0)) + 4);
  out.append("KMSF", 4);
  out.push_back(static_cast<char>(kFrameVersion));
  out.push_back(static_cast<char>((with_status ? kFrameFlagStatus : 0) |
                                  (with_timestamps ? kFrameFlagTimestamps : 0)));
  AppendLe<std::uint16_t>(out, static_cast<std::uint16_t>(run.channel));
  AppendLe<std::uint32_t>(out, static_cast<std::uint32_t>(n));
  AppendLe<std::uint64_t>(out, run.first_counter);
  AppendLe<std::int64_t>(out, run.t_us[0]);
  AppendLe<std::uint32_t>(out, dt_ns);
  for (const double v : run.value_um) AppendLe<std::uint64_t>(out, std::bit_cast<std::uint64_t>(v));
  if (with_timestamps) {
    for (const std::int64_t t : run.t_us) AppendLe<std::int64_t>(out, t);
  }
  if (with_status) {
    if (run.status.empty()) {
      out.append(n, '\0');
    } else {
      out.append(reinterpret_cast<const char*>(run.status.data()), n);
    }
  }
  AppendLe<std::uint32_t>(out, Crc32Update(0, out.data(), out.size()));
  return out;
}

std::string EncodeNdjsonRun(const SampleRun& run) {
  CheckRun(run, std::numeric_limits<std::size_t>::max());
  nlohmann::ordered_json j;
  j["channel"] = run.channel;
  j["first_counter"] = run.first_counter;
  j["t_us"] = run.t_us;
  j["values_um"] = run.value_um;
  if (AnyStatus(run)) j["status"] = run.status;
  return j.dump() + "\n";
}

std::string EncodeNdjsonSample(const StreamSample& sample) {
  if (sample.channel > 65535) throw std::invalid_argument("stream sample: channel > 65535");
  if (!std::isfinite(sample.value_um))
    throw std::invalid_argument("stream sample: value_um not finite");
  nlohmann::ordered_json j;
  j["channel"] = sample.channel;
  j["counter"] = sample.counter;
  j["t_us"] = sample.t_us;
  j["value_um"] = sample.value_um;
  j["status"] = sample.status;
  return j.dump() + "\n";
}

}  // namespace km::ingest
