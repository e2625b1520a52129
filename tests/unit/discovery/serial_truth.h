// Truth simulator of DBB circular tests of a serial (3-axis) machine, INDEPENDENT of the
// product's models: it includes nothing of analysis/ (no effect registry, no signatures, no DBB
// code) and writes contract files (kinemetric-dbb/1, ingest/dbb_parser.cpp) for the product to
// read. Each effect is written again from its physical definition (the comments of the model
// headers, docs/formats.md §4 names, units and signs):
//
//   commanded ball P(θ) = C + R (cos θ, sin θ) in the plane axes (u, v), direction s = +1 ccw,
//   −1 cw; velocity v = s V (−sin θ, cos θ), V = feed/60 mm/s; an axis reverses where its
//   velocity component changes sign (u at θ = 0°, 180°; v at 90°, 270°).
//   backlash_a        e_a = −(b/2) sign(v_a)                         b µm (lost motion)
//   reversal_spike_a  e_a = −h sign(v_a) exp(−φ/w), φ = angle travelled since a's last reversal
//   squareness        e_u = −α·1e-6·v (v = R sin θ in mm → µm)       α µm/m
//   scale_mismatch    e_u = +(Δk/2)·1e-6·u, e_v = −(Δk/2)·1e-6·v      Δk ppm
//   servo_mismatch    e_u = −(+Δτ/2) v_u, e_v = −(−Δτ/2) v_v          Δτ ms, v mm/s → µm
//   cyclic_error_a    e_a = c cos(2π a/P) + d sin(2π a/P), a = the axis position from the centre
//   lateral_play_a    e_other = −(p/2) sign(v_a)                     p µm
//   straightness_a    e_other = S (1 − (a/R)²)                       S µm
// and the bar length is computed exactly: |P + e − F| with F = C + the fixed-ball set-up error,
// dr = (|P + e − F| − R)·1000 + Gaussian noise.
//
// Extra shapes the product does not model (for misfit tests): "soft" backlash, whose lost
// motion is taken up over an angle t after the reversal, e_a = −(b/2) sign(v_a)(1 − 2 e^(−φ/t)).
#pragma once

#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace km::test::truth {

enum class Kind {
  kBacklash,       // p = {b µm}
  kReversalSpike,  // p = {h µm, w deg}
  kSquareness,     // p = {α µm/m}
  kScaleMismatch,  // p = {Δk ppm}
  kServoMismatch,  // p = {Δτ ms}
  kCyclicError,    // p = {c µm, d µm, P mm}
  kLateralPlay,    // p = {p µm}
  kStraightness,   // p = {S µm}
  kSoftBacklash,   // p = {b µm, take-up angle t deg} (not a product model)
};

struct Effect {
  Kind kind = Kind::kBacklash;
  int axis = 0;  // 0 first plane axis, 1 second (per-axis effects)
  std::vector<double> p;
};

struct Test {
  std::string test_id = "T1";
  int direction = +1;  // +1 ccw, −1 cw
  double feed_mm_min = 1000.0;
  double radius_mm = 150.0;
  double start_deg = 0.0;
  double step_deg = 0.1;
  std::uint32_t seed = 1;
};

struct Machine {
  std::string machine_id = "truth";
  std::string plane = "XY";  // XY, YZ or ZX
  std::array<double, 3> centre_mm{0.0, 0.0, 0.0};
  std::array<double, 2> fixed_ball_offset_um{0.0, 0.0};
  double noise_um = 0.3;
  // Disturbances no product model describes (for misfit tests): a radial drift that grows
  // linearly with the time of each test (µm per turn, e.g. thermal growth of the bar), and
  // smooth random noise (µm RMS, first-order autoregressive, correlation angle in degrees).
  double drift_um_per_turn = 0.0;
  double smooth_noise_um = 0.0;
  double smooth_noise_corr_deg = 10.0;
  // Position loop of both axes (0: ideal, the axes are where they are commanded): first-order
  // loop with velocity feed-forward, dx/dt = K_pp (x_c − x) + K_f dx_c/dt, in its steady state
  // on the circle: the axes run on a circle of radius R·|G(jω)|, behind the command by
  // −arg G(jω), G(s) = (K_pp + K_f s)/(K_pp + s), ω = V/R. Every effect is evaluated where the
  // axes are (their positions and directions of motion), not where they are commanded.
  double servo_kpp_per_s = 0.0;
  double servo_kf = 0.0;
  std::vector<Effect> effects;
  std::vector<Test> tests;
};

// Contract name of an effect in the machine's plane, e.g. "backlash_y" ("" for kSoftBacklash).
std::string Name(const Effect& e, const std::string& plane);
// Value the product reports for the effect (docs/formats.md §4: the amplitude √(c² + d²) for the
// cyclic error, else the first parameter).
double Value(const Effect& e);
// Machine position error (µm, plane axes) of one effect at commanded angle θ (rad).
std::array<double, 2> PositionErrorUm(const Effect& e, const Test& t, double theta);
// The DBB file of one test (header per contract, one turn, angle_deg and dr_um columns).
std::string DbbFile(const Machine& m, const Test& t);
// Noise-free dr (µm) of a test at commanded angle θ (rad), with the effects given.
double BarDeviationUm(const Machine& m, const std::vector<Effect>& effects, const Test& t,
                      double theta);
// Detectability z of effect k: the norm of the part of its contribution to the stacked dr that
// neither the set-up terms (centre and radius per test: cos θ, sin θ, 1) nor the other effects'
// linear parameters can absorb, over the noise σ (= |value| / σ(value) for a one-parameter
// effect fitted with the true model; shape parameters known). Columns by finite differences of
// the exact bar length.
double Detectability(const Machine& m, std::size_t k);

// A random machine: `n_effects` distinct kinds among the eight product effects with
// physically signed random sizes (spike height and lateral play > 0, backlash > 0 or, one in
// four, < 0: over-compensated), noise 0.2–0.5 µm, one or two test ids (feeds) of a cw + ccw
// pair each, random plane, radius, start angle and fixed-ball set-up error.
Machine RandomMachine(std::mt19937& rng, int n_effects, const std::string& machine_id);

}  // namespace km::test::truth
