// A laser positioning run simulated from a stated truth, written as a kinemetric-positioning/1
// file (plain loops, none of the product code): systematic deviation e(P) = slope·(P − datum) +
// amplitude·sin(2π·P/period) µm, a reversal (the ↑ approach reads +reversal/2, the ↓ approach
// −reversal/2), seeded Gaussian noise; optionally raw laser readings (n = 1) and a machine
// warmer than 20 °C.
#pragma once

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace km::positioning::test {

struct Truth {
  std::string cycle = "linear";
  std::vector<double> targets_mm;  // in the order the + pass visits them... for a decreasing axis,
                                   // the order the first pass visits them
  int runs = 5;
  double datum_mm = 0.0;
  double slope_um_per_m = 8.0;
  double amplitude_um = 2.5;
  double period_mm = 125.0;
  double reversal_um = 4.0;
  double noise_um = 0.4;
  unsigned seed = 7;
  bool deviation_column = true;
  // Raw readings: the laser used n = 1, so it read (true distance from the datum)·n.
  bool raw = false;
  double air_t_c = 20.8, air_p_pa = 100900.0, air_rh_pct = 45.0, wavelength_nm = 632.991;
  double refractive_index = 1.0;  // n used to write raw readings
  // Machine temperature: the readings carry α·(T − 20)·(P − datum).
  bool warm = false;
  double material_t_c = 23.0, expansion_ppm_per_k = 11.5;
};

inline double TrueDeviationUm(const Truth& t, double p_mm, int direction) {
  return t.slope_um_per_m * (p_mm - t.datum_mm) / 1000.0 +
         t.amplitude_um * std::sin(2.0 * std::numbers::pi * p_mm / t.period_mm) +
         0.5 * direction * t.reversal_um;
}

// The visits of one run: (target, direction) in measuring order.
inline std::vector<std::pair<double, int>> Visits(const Truth& t) {
  std::vector<std::pair<double, int>> v;
  const bool increasing = t.targets_mm.back() > t.targets_mm.front();
  const int first = increasing ? 1 : -1;
  if (t.cycle == "pendulum") {
    for (double p : t.targets_mm) {
      v.push_back({p, first});
      v.push_back({p, -first});
    }
    return v;
  }
  for (double p : t.targets_mm) v.push_back({p, first});
  for (auto it = t.targets_mm.rbegin(); it != t.targets_mm.rend(); ++it) v.push_back({*it, -first});
  return v;
}

inline std::string SimulateFile(const Truth& t) {
  std::mt19937 rng(t.seed);
  std::normal_distribution<double> noise(0.0, t.noise_um);
  std::string s = "# format: kinemetric-positioning/1\n# machine_id: vmc-sim\n# axis: X\n";
  s += "# timestamp: 2024-05-01T10:00:00Z\n# cycle: " + t.cycle + "\n";
  char buf[200];
  std::snprintf(buf, sizeof buf, "# datum_mm: %.3f\n", t.datum_mm);
  s += buf;
  if (t.raw) {
    std::snprintf(buf, sizeof buf,
                  "# air_compensated: no\n# air_temperature_c: %.3f\n# air_pressure_pa: %.1f\n"
                  "# air_humidity_pct: %.2f\n# laser_wavelength_nm: %.4f\n",
                  t.air_t_c, t.air_p_pa, t.air_rh_pct, t.wavelength_nm);
    s += buf;
  } else {
    s += "# air_compensated: yes\n";
  }
  if (t.warm) {
    std::snprintf(buf, sizeof buf, "# material_temperature_c: %.3f\n# expansion_ppm_per_k: %.3f\n",
                  t.material_t_c, t.expansion_ppm_per_k);
    s += buf;
  }
  s += t.deviation_column ? "run,direction,target_mm,deviation_um\n"
                          : "run,direction,target_mm,measured_mm\n";
  for (int run = 1; run <= t.runs; ++run) {
    for (const auto& [p, dir] : Visits(t)) {
      double x_um = TrueDeviationUm(t, p, dir) + noise(rng);
      if (t.warm) x_um += t.expansion_ppm_per_k * (t.material_t_c - 20.0) * (p - t.datum_mm) * 1e-3;
      double reading_mm = p + x_um / 1000.0;
      if (t.raw) reading_mm = t.datum_mm + (reading_mm - t.datum_mm) * t.refractive_index;
      if (t.deviation_column) {
        std::snprintf(buf, sizeof buf, "%d,%s,%.4f,%.6f\n", run, dir > 0 ? "+" : "-", p,
                      (reading_mm - p) * 1000.0);
      } else {
        std::snprintf(buf, sizeof buf, "%d,%s,%.4f,%.9f\n", run, dir > 0 ? "+" : "-", p,
                      reading_mm);
      }
      s += buf;
    }
  }
  return s;
}

}  // namespace km::positioning::test
