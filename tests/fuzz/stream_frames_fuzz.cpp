// Incremental decoder of sensor-stream frames, binary and NDJSON (ingest/stream/stream_frames.h).
// The last bytes of the input choose the format, the per-frame sample limit and how the rest is cut
// into pieces; the rest is the body, fed piece by piece as it would arrive over HTTP. Every
// delivered run must be self-consistent and within the limit.
#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <random>
#include <vector>

#include "ingest/stream/stream_frames.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using km::fuzz::Check;
  namespace ki = km::ingest;
  FuzzedDataProvider in(data, size);
  const bool ndjson = in.ConsumeBool();
  const bool lenient_finish = in.ConsumeBool();
  const std::size_t limit =
      in.ConsumeBool() ? in.ConsumeIntegralInRange<std::size_t>(1, 64) : ki::kFrameMaxSamples;
  const auto seed = in.ConsumeIntegral<std::uint32_t>();
  const std::string body = in.ConsumeRemainingBytesAsString();

  ki::StreamFrameDecoder decoder(ndjson ? ki::FrameFormat::kNdjson : ki::FrameFormat::kBinary,
                                 "fuzz", limit);
  std::uint64_t runs = 0, samples = 0;
  const auto on_run = [&](ki::SampleRun&& r) {
    ++runs;
    samples += r.size();
    Check(r.size() >= 1 && r.size() <= limit, "a run holds 1 … limit samples");
    Check(r.t_us.size() == r.size() && r.status.size() == r.size(), "one time, status a value");
    Check(r.channel <= 65535, "channel within 0 … 65535");
    for (double v : r.value_um) Check(std::isfinite(v), "finite values");
  };
  std::minstd_rand rng(seed);
  std::uniform_int_distribution<std::size_t> piece(0, 97);
  km::fuzz::Guarded([&] {
    for (std::size_t at = 0; at < body.size();) {
      const std::size_t len = std::min(piece(rng), body.size() - at);
      decoder.Feed(std::string_view(body).substr(at, len), on_run);
      at += len;
    }
    if (lenient_finish) {
      decoder.Finish(on_run);
    } else {
      decoder.Finish();
    }
  });
  Check(decoder.frames() == runs, "frames() counts the delivered runs");
  Check(decoder.samples() == samples, "samples() counts the delivered samples");
  return 0;
}
