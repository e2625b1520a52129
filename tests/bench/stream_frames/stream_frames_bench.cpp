// Decoding throughput of HTTP stream frames (ingest/stream/stream_frames.h): binary frames and
// NDJSON lines of 1000 samples, whole buffers and 4 KiB network-sized pieces. items/s = samples/s.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <string>

#include "ingest/crc32.h"
#include "ingest/stream/stream_frames.h"

namespace km::ingest {
namespace {

constexpr int kFrames = 100;
constexpr std::size_t kSamples = 1000;
constexpr std::uint32_t kDtNs = 20000;  // 50 kHz

SampleRun MakeRun(std::mt19937& rng, std::uint64_t first_counter, std::int64_t t0_us) {
  std::normal_distribution<double> value(0.0, 25.0);
  SampleRun r;
  r.channel = 3;
  r.first_counter = first_counter;
  for (std::size_t k = 0; k < kSamples; ++k) {
    r.value_um.push_back(value(rng));
    r.t_us.push_back(t0_us + static_cast<std::int64_t>((k * kDtNs + 500) / 1000));
    r.status.push_back(0);
  }
  return r;
}

std::string BinaryStream(bool timestamps, bool status) {
  std::mt19937 rng(1);
  std::string s;
  for (int f = 0; f < kFrames; ++f) {
    const std::int64_t t0 = 1763700000000000 + f * static_cast<std::int64_t>(kSamples) * 20;
    s += EncodeBinaryFrame(MakeRun(rng, f * kSamples, t0), timestamps, status, kDtNs);
  }
  return s;
}

std::string NdjsonStream(bool uniform) {
  std::mt19937 rng(2);
  std::string s;
  for (int f = 0; f < kFrames; ++f) {
    const std::int64_t t0 = 1763700000000000 + f * static_cast<std::int64_t>(kSamples) * 20;
    const SampleRun run = MakeRun(rng, f * kSamples, t0);
    if (!uniform) {
      s += EncodeNdjsonRun(run);
      continue;
    }
    std::string line = EncodeNdjsonRun(run);  // replace the t_us array by t0_us / dt_us
    const auto a = line.find("\"t_us\":[");
    const auto b = line.find(']', a);
    line.replace(a, b - a + 1, "\"t0_us\":" + std::to_string(t0) + ",\"dt_us\":20");
    s += line;
  }
  return s;
}

void Decode(benchmark::State& state, FrameFormat format, const std::string& bytes,
            std::size_t piece) {
  std::uint64_t samples = 0;
  double checksum = 0;
  for (auto _ : state) {
    StreamFrameDecoder dec(format, "bench");
    auto sink = [&](SampleRun&& r) { checksum += r.value_um[0]; };
    for (std::size_t at = 0; at < bytes.size(); at += piece) {
      dec.Feed(std::string_view(bytes).substr(at, piece), sink);
    }
    dec.Finish();
    samples += dec.samples();
  }
  benchmark::DoNotOptimize(checksum);
  state.SetItemsProcessed(static_cast<std::int64_t>(samples));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes.size()));
}

void BM_DecodeBinary(benchmark::State& state) {
  const bool ts = state.range(0) & 2, st = state.range(0) & 1;
  const std::string bytes = BinaryStream(ts, st);
  const auto piece = static_cast<std::size_t>(state.range(1));
  Decode(state, FrameFormat::kBinary, bytes, piece == 0 ? bytes.size() : piece);
}
// Args: flags (bit0 status, bit1 timestamps), piece size (0 = whole buffer).
BENCHMARK(BM_DecodeBinary)
    ->ArgNames({"flags", "piece"})
    ->Args({0, 0})
    ->Args({3, 0})
    ->Args({0, 4096})
    ->Args({3, 4096});

void BM_DecodeNdjsonRun(benchmark::State& state) {
  const std::string bytes = NdjsonStream(state.range(0) != 0);
  const auto piece = static_cast<std::size_t>(state.range(1));
  Decode(state, FrameFormat::kNdjson, bytes, piece == 0 ? bytes.size() : piece);
}
// Args: uniform (1: t0_us/dt_us, 0: t_us array), piece size (0 = whole buffer).
BENCHMARK(BM_DecodeNdjsonRun)
    ->ArgNames({"uniform", "piece"})
    ->Args({0, 0})
    ->Args({1, 0})
    ->Args({0, 4096});

void BM_DecodeNdjsonSamples(benchmark::State& state) {
  std::string bytes;
  for (std::size_t k = 0; k < 10000; ++k) {
    bytes += EncodeNdjsonSample({1, k, 1763700000000000 + static_cast<std::int64_t>(k) * 20,
                                 std::sin(0.001 * static_cast<double>(k)), 0});
  }
  Decode(state, FrameFormat::kNdjson, bytes, bytes.size());
}
BENCHMARK(BM_DecodeNdjsonSamples);

void BM_Crc32(benchmark::State& state) {
  std::string data(static_cast<std::size_t>(state.range(0)), '\0');
  std::mt19937 rng(3);
  for (char& c : data) c = static_cast<char>(rng());
  std::uint32_t crc = 0;
  for (auto _ : state) {
    crc ^= Crc32(data);
    benchmark::DoNotOptimize(crc);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * data.size()));
}
BENCHMARK(BM_Crc32)->Arg(8036)->Arg(1 << 20);

void BM_EncodeBinary(benchmark::State& state) {
  std::mt19937 rng(4);
  const SampleRun run = MakeRun(rng, 0, 1763700000000000);
  for (auto _ : state) {
    std::string s = EncodeBinaryFrame(run, false, false, kDtNs);
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kSamples));
}
BENCHMARK(BM_EncodeBinary);

}  // namespace
}  // namespace km::ingest

BENCHMARK_MAIN();
