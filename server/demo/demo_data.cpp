#include "server/demo/demo_data.h"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "analysis/dbb/serial_sim.h"
#include "ingest/dbb_writer.h"
#include "ingest/stream/stream_frames.h"
#include "server/streams/stream_service.h"

namespace km::server {
namespace {

struct DemoTest {
  const char* test_id;
  dbb::Plane plane;
  double radius_mm;
  double feed_mm_min;
  const char* timestamp;
  double squareness_um_per_m;  // positive: angle between the axes > 90°
  double mismatch_ms;          // τ(first axis) − τ(second axis)
  double backlash_um;          // first axis
  double scale_ppm;            // first axis − second axis
};

}  // namespace

std::vector<DemoFile> DemoDbbFiles() {
  // A machining centre drifting over three months: squareness, servo mismatch and backlash
  // grow; one faster, smaller circle and one YZ test on the last day.
  const DemoTest tests[] = {
      {"xy-r150", dbb::Plane::kXY, 150.0, 1000.0, "2026-09-02T08:10:00Z", 12.0, 0.6, 1.5, 4.0},
      {"xy-r150", dbb::Plane::kXY, 150.0, 1000.0, "2026-10-01T08:05:00Z", 14.0, 0.8, 2.2, 4.0},
      {"xy-r150", dbb::Plane::kXY, 150.0, 1000.0, "2026-11-02T07:58:00Z", 15.0, 1.1, 3.0, 5.0},
      {"xy-r100-f2000", dbb::Plane::kXY, 100.0, 2000.0, "2026-11-02T08:30:00Z", 15.0, 1.1, 3.0,
       5.0},
      {"yz-r150", dbb::Plane::kYZ, 150.0, 1000.0, "2026-11-02T09:00:00Z", -8.0, -0.4, 1.0, -3.0},
  };
  std::vector<DemoFile> out;
  std::uint32_t seed = 7;
  for (const auto& t : tests) {
    for (const auto dir : {dbb::Direction::kCcw, dbb::Direction::kCw}) {
      dbb::SerialDbbSimOptions o;
      o.machine_id = "demo-vmc";
      o.test_id = t.test_id;
      o.direction = dir;
      o.plane = t.plane;
      o.radius_mm = t.radius_mm;
      o.bar_length_mm = t.radius_mm;
      o.feed_mm_min = t.feed_mm_min;
      o.noise_um = 0.08;
      o.seed = seed++;
      o.effects = {{serial_effects::EffectId::kSquareness, {t.squareness_um_per_m}},
                   {serial_effects::EffectId::kServoMismatch, {t.mismatch_ms}},
                   {serial_effects::EffectId::kBacklashU, {t.backlash_um}},
                   {serial_effects::EffectId::kScaleMismatch, {t.scale_ppm}}};
      dbb::DbbTest test = dbb::SimulateSerialDbbTest(o);
      test.timestamp = t.timestamp;
      test.temperature_c = 20.4;
      test.metadata["operator"] = "demo data (generated)";
      const std::string name = std::string("demo-") + t.test_id + "-" +
                               std::string(t.timestamp).substr(0, 10) + "-" + dbb::ToString(dir) +
                               ".dbb";
      out.push_back(DemoFile{name, ingest::WriteDbb(test)});
    }
  }
  return out;
}

DemoFile DemoPositioningFile() {
  std::string text =
      "# format: kinemetric-positioning/1\n# machine_id: demo-vmc\n# axis: X\n"
      "# timestamp: 2026-11-02T09:40:00Z\n# cycle: pendulum\n# datum_mm: 0\n"
      "# air_compensated: yes\n# material_temperature_c: 21.0\n# expansion_ppm_per_k: 11.5\n"
      "# operator: demo data (generated)\nrun,direction,target_mm,deviation_um\n";
  std::mt19937 rng(2302);
  std::normal_distribution<double> noise(0.0, 0.3);
  const auto deviation = [&](double x, int dir) {
    const double scale = 11.5e-3 * (21.0 - 20.0) * x;  // the warm scale, µm
    return 0.012 * x + 1.2 * std::sin(2 * std::numbers::pi * x / 100.0 + 0.3) + 1.5 * dir + scale +
           noise(rng);
  };
  for (int run = 1; run <= 5; ++run) {
    for (int k = 0; k <= 10; ++k) {  // pendulum: each target ↑ then ↓
      const double x = 50.0 * k;
      for (const int dir : {1, -1}) {
        char row[96];
        std::snprintf(row, sizeof row, "%d,%s,%.1f,%.4f\n", run, dir > 0 ? "+" : "-", x,
                      deviation(x, dir));
        text += row;
      }
    }
  }
  return DemoFile{"demo-positioning-x-2026-11-02.txt", text};
}

StreamId LoadDemoStream(StreamService& streams) {
  const nlohmann::json request = {
      {"machine_id", "demo-vmc"},
      {"name", "optical flat, X travel 300 mm"},
      {"channels",
       {{{"channel", 1}, {"name", "capacitance Z"}, {"unit", "um"}, {"rate_hz", 2000}},
        {{"channel", 2}, {"name", "X encoder"}, {"unit", "um"}, {"rate_hz", 2000}}}}};
  const StreamId id = streams.CreateStream(request);
  constexpr double kRate = 2000.0, kFeed = 600.0, kTravel = 300.0, kStart = 50.0;
  const auto n = static_cast<std::size_t>(kTravel / (kFeed / 60.0) * kRate);  // 30 s
  const std::int64_t t0 = 1'793'600'000'000'000;  // 2026-11-02 08:53:20 UTC
  std::mt19937 rng(2026);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::string frames;
  constexpr std::size_t kFrame = 200;  // 0.1 s
  for (std::size_t b = 0; b < n; b += kFrame) {
    ingest::SampleRun sensor, encoder;
    sensor.channel = 1;
    encoder.channel = 2;
    sensor.first_counter = encoder.first_counter = b;
    for (std::size_t k = b; k < std::min(n, b + kFrame); ++k) {
      const std::int64_t t = t0 + static_cast<std::int64_t>(k) * 500;
      const double x = kStart + kFeed / 60.0 * static_cast<double>(k) / kRate;
      const double z = 0.2 * std::sin(2 * std::numbers::pi * x / 55.0) +
                       0.05 * std::sin(2 * std::numbers::pi * x / 10.0 + 0.7) + 0.004 * x;
      sensor.t_us.push_back(t);
      sensor.value_um.push_back(z + noise(rng));
      sensor.status.push_back(0);
      encoder.t_us.push_back(t);
      encoder.value_um.push_back(std::round(x * 1e4) / 10.0);  // 0.1 µm encoder resolution
      encoder.status.push_back(0);
    }
    if (b != 150 * kFrame) frames += ingest::EncodeBinaryFrame(sensor, false, false, 500'000);
    frames += ingest::EncodeBinaryFrame(encoder, false, false, 500'000);
  }
  streams.IngestFrames(id, "application/vnd.kinemetric.stream-frame",
                       [&frames](const std::function<bool(std::string_view)>& sink) {
                         sink(frames);
                         return true;
                       });
  streams.StreamProfile(id, {{"channel", 1},
                             {"axis", "X"},
                             {"error_direction", "Z"},
                             {"test_id", "x-flat-300"},
                             {"points", 1500},
                             {"position", {{"encoder_channel", 2}}}});
  return id;
}

}  // namespace km::server
