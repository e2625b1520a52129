// Independent simulator of a feed drive's motor force for the recover-the-truth tests of
// `servo feed-drive` (analysis/servo/feed_drive.h). It shares no code with analysis/servo: the
// motion is analytic (trapezoidal speed with constant acceleration, or cosine ramps, dwells at
// the reversals), the LuGre bristle state of [Fujita thesis] eqs. 4.1–4.2,
//   dz/dt = v − σ0 |v| z / g(v),  g(v) = F_c + (F_s − F_c) exp(−|v/v_s|^δ)
//   (or the Lorentzian of Hess and Soom, F_c + (F_s − F_c) / (1 + (v/v_s)²)),
//   F = σ0 z + σ1 dz/dt + σ2 v + m a + c0 + c1 x + A sin(2π x / P + φ) + noise,
// is integrated by RK4 on sub-steps of the continuous motion. It writes `kinemetric-servo/1`.
// The thesis leaves g(v) open: δ = 2 is the Gaussian of the LuGre paper, δ = 1 the exponential.
#pragma once

#include <string>
#include <vector>

namespace km::servo::feed_truth {

struct Drive {
  double fc_N = 30.0, fs_N = 36.0, vs_mm_s = 2.0;
  double stribeck_exponent = 2.0;  // δ
  bool lorentzian = false;         // g(v) = F_c + (F_s − F_c) / (1 + (v/v_s)²) instead
  double sigma0_N_per_um = 5.0, sigma1_N_s_per_mm = 8.0, sigma2_N_s_per_mm = 0.05;
  double mass_kg = 40.0;
  double offset_N = 12.0, slope_N_per_mm = 0.0;
  double ripple_N = 3.0, ripple_mm = 55.0, ripple_phase_rad = 0.4;
  double noise_N = 0.3;
};

// One move from the current position to `to_mm` at `speed_mm_s`.
struct Move {
  double to_mm = 0.0, speed_mm_s = 0.0;
};

struct Motion {
  double start_mm = 0.0;
  std::vector<Move> moves;
  double accel_mm_s2 = 500.0;  // trapezoid; with cosine ramps the peak acceleration
  bool cosine_ramps = false;   // speed ramps 0.5 (1 − cos) instead of constant acceleration
  double dwell_s = 0.0;        // standstill before the first move, between moves, after the last
  double sample_s = 2e-3;
  int substeps = 40;  // RK4 steps a sample interval (more when the interval exceeds 1 ms)
};

// Strokes of `stroke_mm` out and back at each speed in turn, from 0.
Motion BackAndForth(double stroke_mm, const std::vector<double>& speeds_mm_s, int round_trips = 1);

struct Trace {
  std::vector<double> t_s, x_mm, v_mm_s, a_mm_s2, force_N;
};

Trace Simulate(const Drive& d, const Motion& m, unsigned seed);

// `kinemetric-servo/1` text of the trace (axis X).
std::string ServoText(const Trace& t, const std::string& test_id = "x-strokes");

}  // namespace km::servo::feed_truth
