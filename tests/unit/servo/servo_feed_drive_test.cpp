// Recover-the-truth tests of the feed-drive friction analysis (analysis/servo/feed_drive.h):
// an independent simulator drives the axis over strokes at three feeds with slow reversals and
// integrates its own LuGre model (RK4, small sub-steps) plus a 55 mm force ripple, an offset
// and noise; the analysis reads the records back through the parser.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "analysis/core/errors.h"
#include "analysis/servo/feed_drive.h"
#include "ingest/servo_parser.h"

namespace km::servo {
namespace {

struct Truth {
  double fc = 30.0, fs = 36.0, vs = 2.0, sigma0 = 5.0, sigma1 = 0.5, sigma2 = 0.05;
  double ripple_mm = 55.0, ripple_N = 3.0, offset_N = 12.0, noise_N = 0.3;
};

// dz/dt of the LuGre bristles, z in µm, v in mm/s.
double Zdot(const Truth& m, double z, double v) {
  const double g = m.fc + (m.fs - m.fc) * std::exp(-(v / m.vs) * (v / m.vs));
  return 1e3 * v - m.sigma0 * std::abs(1e3 * v) * z / g;
}

// Strokes between 0 and `stroke` mm at `feed` mm/min: cosine speed ramps of 1 s, reversals
// without dwell, sampled at 1 kHz; returns the kinemetric-servo/1 text.
std::string Record(const Truth& m, double feed_mm_min, double stroke, int strokes, unsigned seed) {
  const double vmax = feed_mm_min / 60.0, ramp = 1.0, dt = 1e-3;
  const double cruise = (stroke - vmax * ramp) / vmax;
  const double leg = 2 * ramp + cruise;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, m.noise_N);
  std::string s = "# format: kinemetric-servo/1\n# machine_id: vmc\n# test_id: feed" +
                  std::to_string(static_cast<int>(feed_mm_min)) +
                  "\n# motion: path\n# axis: X\n# force_unit: N\nt_s,pos_mm,force\n";
  const auto speed = [&](double t) {
    const int k = static_cast<int>(t / leg);
    const double u = t - k * leg, dir = k % 2 == 0 ? 1.0 : -1.0;
    double v = vmax;
    if (u < ramp) v = vmax * 0.5 * (1 - std::cos(std::numbers::pi * u / ramp));
    if (u > ramp + cruise) v = vmax * 0.5 * (1 - std::cos(std::numbers::pi * (leg - u) / ramp));
    return dir * v;
  };
  double x = 0.0, z = 0.0;
  const int sub = 50;
  const long n = static_cast<long>(strokes * leg / dt);
  char buf[96];
  for (long i = 0; i < n; ++i) {
    const double t = i * dt;
    const double v = speed(t);
    const double zd = Zdot(m, z, v);
    const double f = m.sigma0 * z + m.sigma1 * 1e-3 * zd + m.sigma2 * v + m.offset_N +
                     m.ripple_N * std::sin(2 * std::numbers::pi * x / m.ripple_mm + 0.4);
    std::snprintf(buf, sizeof buf, "%.4f,%.7f,%.4f\n", t, x, f + noise(rng));
    s += buf;
    for (int k = 0; k < sub; ++k) {  // RK4 on (x, z)
      const double h = dt / sub, tk = t + k * h;
      const double v1 = speed(tk), v2 = speed(tk + h / 2), v4 = speed(tk + h);
      const double k1 = Zdot(m, z, v1), k2 = Zdot(m, z + h / 2 * k1, v2);
      const double k3 = Zdot(m, z + h / 2 * k2, v2), k4 = Zdot(m, z + h * k3, v4);
      z += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
      x += h / 6 * (v1 + 4 * v2 + v4);
    }
  }
  return s;
}

TEST(ServoFeedDrive, SeparatesRippleCoulombViscousAndLugre) {
  const Truth m;
  std::vector<ServoFile> files;
  const double feeds[] = {600.0, 1800.0, 4800.0};
  for (int k = 0; k < 3; ++k) {
    files.push_back(ingest::ParseServoFile(Record(m, feeds[k], 220.0, 4, 7 + k), "feed.txt"));
  }
  std::vector<const ServoFile*> ptr;
  for (const auto& f : files) ptr.push_back(&f);
  FeedDriveOptions o;
  o.radius_mm = 50.0;
  o.feed_mm_min = 1000.0;
  o.kp_per_s = 30.0;
  const FeedDriveResult r = AnalyzeFeedDrive(ptr, "X", o);
  EXPECT_NEAR(r.coulomb_N, m.fc, 0.05 * m.fc);
  EXPECT_NEAR(r.viscous_N_s_per_mm, m.sigma2, 0.2 * m.sigma2);
  ASSERT_FALSE(r.ripple.empty());
  EXPECT_NEAR(r.ripple[0].period_mm, m.ripple_mm, 0.02 * m.ripple_mm);
  EXPECT_NEAR(r.ripple[0].amplitude_N, m.ripple_N, 0.15 * m.ripple_N);
  EXPECT_NEAR(r.offset_N, m.offset_N, 1.0);
  ASSERT_TRUE(r.lugre.has_value()) << r.lugre_note;
  EXPECT_NEAR(r.lugre->Fc_N, m.fc, 0.15 * m.fc);
  EXPECT_NEAR(r.lugre->sigma0_N_per_um, m.sigma0, 0.15 * m.sigma0);
  EXPECT_EQ(r.reversals, 3u * 3u);  // four strokes a record
  ASSERT_TRUE(r.stick_motion_um.has_value());
  // d = 2 Fc/σ0 = 12 µm; t_d = √(2·0.012·50)/16.7 s = 0.066 s; h = 12/(1 + 30·0.066) ≈ 4.0 µm.
  EXPECT_NEAR(*r.stick_motion_um, 4.0, 0.8);
  // Only the 55 mm ripple is reported (nothing spurious from the stroke ends).
  EXPECT_EQ(r.ripple.size(), 1u);
}

TEST(ServoFeedDrive, NeedsBothDirections) {
  std::string s =
      "# format: kinemetric-servo/1\n# machine_id: m\n# test_id: t\n# motion: path\n"
      "# axis: X\n# force_unit: N\nt_s,pos_mm,force\n";
  for (int i = 0; i < 100; ++i) s += std::to_string(0.01 * i) + "," + std::to_string(i) + ",1\n";
  const ServoFile f = ingest::ParseServoFile(s, "one-way.txt");
  EXPECT_THROW(AnalyzeFeedDrive({&f}, "X"), km::InvalidInput);
  EXPECT_THROW(AnalyzeFeedDrive({&f}, "Y"), km::InvalidInput);
}

}  // namespace
}  // namespace km::servo
