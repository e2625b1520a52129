#include "server/demo_data.h"

#include "analysis/dbb/serial_sim.h"
#include "ingest/dbb_writer.h"

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
      o.effects = {{effects::EffectId::kSquareness, {t.squareness_um_per_m}},
                   {effects::EffectId::kServoMismatch, {t.mismatch_ms}},
                   {effects::EffectId::kBacklashU, {t.backlash_um}},
                   {effects::EffectId::kScaleMismatch, {t.scale_ppm}}};
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

}  // namespace km::server
