// Periodic components of a residual profile r(x) sampled at arbitrary (non-uniform) positions,
// e.g. guide waviness ([Fujita thesis] fig. 4.10: 0.4 um P-V, ~55 mm period) or ball-screw lead
// error ([Fujita thesis] ch. 8: 10 mm lead).
//
// Baseline: a polynomial of degree detrend_degree (default 2: offset, slope, bow) is removed
// first and fitted jointly with every sinusoid, so smooth form is not reported as long periods.
// Search: generalised Lomb-Scargle periodogram. For each trial frequency f the model
// r_i = c + a cos(2 pi f x_i) + b sin(2 pi f x_i) is fitted by least squares and its power is
// the drop of the residual sum of squares, dRSS(f). Frequencies run from 1/max_period to
// 1/min_period in steps of 1/(oversampling * L), L the profile length; the best one is refined
// by golden-section search on dRSS(f) within one step either side.
// Significance: with sigma^2 estimated from the residual after the fit, z = dRSS / (2 sigma^2)
// is Exp(1)-distributed for white Gaussian noise, so the false-alarm probability over the
// M trial frequencies is at most FAP = 1 - (1 - exp(-z))^M (M counts every grid frequency, more
// than the (f_max - f_min) L independent ones: conservative). A component is
// kept when FAP < false_alarm_probability; it is then removed and the search repeated.
// Finally the amplitudes of all kept components are re-fitted jointly together with the
// baseline, r_i = poly(x_i) + sum_k (a_k cos + b_k sin)(2 pi f_k x_i).
#pragma once

#include <span>
#include <vector>

namespace km::form {

struct PeriodicOptions {
  double min_period_mm = 0.0;  // 0: max(2.5 x median spacing, length / 500)
  double max_period_mm = 0.0;  // 0: length / 2.5 (at least 2.5 cycles in the profile)
  int detrend_degree = 2;      // polynomial baseline removed with / fitted jointly to the sines
  double oversampling = 5.0;   // frequency steps per 1/L
  double false_alarm_probability = 1e-3;
  int max_components = 5;
  // Throws InvalidInput when an option is out of range.
  void Check() const;
};

struct PeriodicComponent {
  double period_mm = 0.0;
  double amplitude_um = 0.0;  // half the peak-to-valley of the sinusoid
  double phase_rad = 0.0;     // r = amplitude * cos(2 pi x / period - phase)
  double false_alarm_probability = 1.0;
};

// Significant periodic components of r(x), strongest first. x need not be uniform nor sorted;
// fewer than 8 points give no components. Throws InvalidInput when sizes differ.
std::vector<PeriodicComponent> FindPeriodicComponents(std::span<const double> position_mm,
                                                      std::span<const double> residual_um,
                                                      const PeriodicOptions& options = {});

}  // namespace km::form
