#include "server/demo_data.h"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

namespace km::server {
namespace {

struct DemoTest {
  const char* test_id;
  const char* plane;
  double radius_mm;
  double feed_mm_min;
  const char* timestamp;
  double squareness_um_per_m;  // angle between axes > 90° positive
  double mismatch_ms;          // τ(first axis) − τ(second axis)
  double backlash_um;          // first axis
  double scale_ppm;            // first axis − second axis
};

std::string MakeFile(const DemoTest& d, bool ccw, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.08);
  const double sign = ccw ? 1.0 : -1.0;
  const double r_um = d.radius_mm * 1000.0;
  const double omega = sign * d.feed_mm_min / 60.0 / d.radius_mm;  // rad/s
  std::string out;
  char buf[256];
  out += "# format: kinemetric-dbb/1\n# machine_id: demo-vmc\n";
  out += std::string("# test_id: ") + d.test_id + "\n# direction: " + (ccw ? "ccw" : "cw") + "\n";
  out += std::string("# plane: ") + d.plane + "\n";
  std::snprintf(buf, sizeof buf,
                "# bar_length_mm: %.3f\n# centre_mm: 0, 0, 0\n# feed_mm_min: %.1f\n", d.radius_mm,
                d.feed_mm_min);
  out += buf;
  out += std::string("# timestamp: ") + d.timestamp + "\n# temperature_c: 20.4\n";
  out += "# operator: demo data (generated)\nangle_deg,dr_um\n";
  const int n = 3600;
  for (int i = 0; i < n; ++i) {
    const double deg = sign * 360.0 * i / n;
    const double th = deg * std::numbers::pi / 180.0;
    const double c = std::cos(th), s = std::sin(th);
    // Machine position error (first, second axis), µm; radial error = e · u(θ).
    // Squareness: the second axis leans towards −first when the angle exceeds 90°.
    double ex = -d.squareness_um_per_m * 1e-6 * (r_um * s);
    double ey = 0.0;
    // Servo lag: each axis lags its command by τ·v.
    const double vx = -omega * r_um * s, vy = omega * r_um * c;  // µm/s
    ex += -(d.mismatch_ms / 2.0) * 1e-3 * vx;
    ey += (d.mismatch_ms / 2.0) * 1e-3 * vy;
    // Backlash of the first axis: half the lost motion, opposite to its velocity.
    ex += -(vx > 0 ? 1.0 : -1.0) * d.backlash_um / 2.0;
    ex += d.scale_ppm * 1e-6 * (r_um * c);
    const double dr = ex * c + ey * s + noise(rng);
    std::snprintf(buf, sizeof buf, "%.4f,%.5f\n", deg, dr);
    out += buf;
  }
  return out;
}

}  // namespace

std::vector<DemoFile> DemoDbbFiles() {
  const DemoTest tests[] = {
      {"xy-r150", "XY", 150.0, 1000.0, "2026-09-02T08:10:00Z", 12.0, 0.6, 1.5, 4.0},
      {"xy-r150", "XY", 150.0, 1000.0, "2026-10-01T08:05:00Z", 14.0, 0.8, 2.2, 4.0},
      {"xy-r150", "XY", 150.0, 1000.0, "2026-11-02T07:58:00Z", 15.0, 1.1, 3.0, 5.0},
      {"xy-r100-f2000", "XY", 100.0, 2000.0, "2026-11-02T08:30:00Z", 15.0, 1.1, 3.0, 5.0},
      {"yz-r150", "YZ", 150.0, 1000.0, "2026-11-02T09:00:00Z", -8.0, -0.4, 1.0, -3.0},
  };
  std::vector<DemoFile> out;
  unsigned seed = 7;
  for (const auto& t : tests) {
    for (bool ccw : {true, false}) {
      const std::string name = std::string("demo-") + t.test_id + "-" +
                               std::string(t.timestamp).substr(0, 10) + (ccw ? "-ccw" : "-cw") +
                               ".dbb";
      out.push_back(DemoFile{name, MakeFile(t, ccw, seed++)});
    }
  }
  return out;
}

}  // namespace km::server
