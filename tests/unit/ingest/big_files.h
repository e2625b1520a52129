// Large measurement files for the parse-memory test and the ingest benchmark: short rows, as
// a high-rate sensor writes them.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

namespace km::test {

// A DBB test (one turn, `samples` rows "angle,dr" of about 20 bytes).
inline std::string BigDbbFile(std::size_t samples) {
  std::string s =
      "# format: kinemetric-dbb/1\n# machine_id: m1\n# test_id: big\n# direction: ccw\n"
      "# bar_length_mm: 150\n# centre_mm: 0, 0, 0\n# feed_mm_min: 1000\nangle_deg,dr_um\n";
  s.reserve(s.size() + 21 * samples);
  char buf[64];
  for (std::size_t i = 0; i < samples; ++i) {
    const double a = 360.0 * static_cast<double>(i) / static_cast<double>(samples);
    const double th = a * 3.14159265358979 / 180.0;
    const int n = std::snprintf(
        buf, sizeof buf, "%.6f,%.6f\n", a,
        2.0 * std::cos(2 * th) + 0.5 * std::sin(3 * th) + 0.01 * static_cast<double>(i % 17));
    s.append(buf, static_cast<std::size_t>(n));
  }
  return s;
}

// A straightness profile over 1 m (`points` rows "position,deviation").
inline std::string BigStraightnessFile(std::size_t points) {
  std::string s =
      "# format: kinemetric-straightness/1\n# machine_id: m1\n# axis: X\n# error_direction: Y\n"
      "# sensor: capacitance\n# reference: straightedge\nposition_mm,deviation_um\n";
  s.reserve(s.size() + 21 * points);
  char buf[64];
  for (std::size_t i = 0; i < points; ++i) {
    const double x = 1000.0 * static_cast<double>(i) / static_cast<double>(points);
    const int n = std::snprintf(buf, sizeof buf, "%.6f,%.6f\n", x,
                                0.2 * std::cos(2 * 3.14159265358979 * x / 55) + 1e-4 * x +
                                    0.01 * static_cast<double>(i % 13));
    s.append(buf, static_cast<std::size_t>(n));
  }
  return s;
}

// A flatness grid of side × side points.
inline std::string BigFlatnessFile(std::size_t side) {
  std::string s = "# format: kinemetric-flatness/1\n# machine_id: m1\nx_mm,y_mm,z_um\n";
  s.reserve(s.size() + 26 * side * side);
  char buf[96];
  for (std::size_t j = 0; j < side; ++j) {
    for (std::size_t i = 0; i < side; ++i) {
      const double x = 1000.0 * static_cast<double>(i) / static_cast<double>(side);
      const double y = 800.0 * static_cast<double>(j) / static_cast<double>(side);
      const int n = std::snprintf(buf, sizeof buf, "%.4f,%.4f,%.5f\n", x, y,
                                  0.5 * std::sin(x / 100) + 0.3 * std::cos(y / 70));
      s.append(buf, static_cast<std::size_t>(n));
    }
  }
  return s;
}

// A survey of side³ points read by `trackers` trackers (readings are not consistent distances:
// for the parser only).
inline std::string BigTrackerFile(std::size_t side, int trackers = 4) {
  std::string s =
      "# format: kinemetric-tracker/1\n# machine_id: m1\n# trackers: " + std::to_string(trackers) +
      "\n# mode: simultaneous\npoint,x_mm,y_mm,z_mm";
  for (int j = 1; j <= trackers; ++j) s += ",d" + std::to_string(j) + "_um";
  s += "\n";
  s.reserve(s.size() + (30 + 13 * static_cast<std::size_t>(trackers)) * side * side * side);
  char buf[64];
  std::size_t id = 0;
  for (std::size_t k = 0; k < side; ++k) {
    for (std::size_t j = 0; j < side; ++j) {
      for (std::size_t i = 0; i < side; ++i) {
        ++id;
        int n = std::snprintf(buf, sizeof buf, "%zu,%.3f,%.3f,%.3f", id, 200.0 + 8.0 * i,
                              100.0 + 8.0 * j, 50.0 + 8.0 * k);
        s.append(buf, static_cast<std::size_t>(n));
        for (int t = 0; t < trackers; ++t) {
          n = std::snprintf(buf, sizeof buf, ",%.4f", id == 1 ? 0.0 : 1000.0 * std::sin(id + t));
          s.append(buf, static_cast<std::size_t>(n));
        }
        s += "\n";
      }
    }
  }
  return s;
}

}  // namespace km::test
