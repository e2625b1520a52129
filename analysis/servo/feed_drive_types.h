// The options and the result of the feed-drive friction analysis (analysis/servo/feed_drive.h,
// which runs it): a header of their own, so the steps of the analysis (feed_drive_detail.h) use
// them without including the analysis they are parts of.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "analysis/servo/servo_types.h"

namespace km::servo {

struct FeedDriveOptions {
  double min_speed_fraction = 0.5;  // steady: |v| >= this × its stroke's top speed (cruise)…
  double reversal_skip_mm = 2.0;    // …and this far from the last reversal
  double bin_mm = 0.5;              // bins of the position-dependent part
  int max_ripple_components = 3;
  double min_period_mm = 2.0;    // 0: four bins
  double max_period_mm = 0.0;    // 0: half the steady samples' travel (two periods at least)
  double lugre_window_mm = 1.0;  // travel either side of a reversal fitted by LuGre
  bool fit_lugre = true;
  // Stick-motion prediction, when all three are given.
  std::optional<double> radius_mm, feed_mm_min, kp_per_s;
  void Check() const;
};

struct Ripple {
  double period_mm = 0.0, period_sigma_mm = 0.0;
  double amplitude_N = 0.0, amplitude_sigma_N = 0.0;
  double phase_deg = 0.0;
};

struct LugreParameters {
  double Fc_N = 0.0, Fs_N = 0.0, vs_mm_s = 0.0;
  double sigma0_N_per_um = 0.0, sigma1_N_s_per_mm = 0.0, sigma2_N_s_per_mm = 0.0;
  // δ of the Stribeck rise exp(−|v/v_s|^δ): the thesis leaves g(v) open; 2 is the Gaussian of
  // the LuGre paper, 1 the exponential. Fitted where the reversals resolve the rise's shape.
  double stribeck_exponent = 2.0;
  // The form of the rise: exp(−|v/v_s|^δ), or the Lorentzian of Hess and Soom
  // 1/(1 + (v/v_s)²) (δ then unused, 2), whose tail is long. Where both fit the reversals
  // comparably the σ of F_s and v_s cover the spread between them.
  enum class Form { kExponential, kLorentzian } stribeck_form = Form::kExponential;
};

// Which LuGre parameters the records determine (a σ below a third of the value, or of a
// scale for values near zero: 10 % of the critical damping 2√(σ0 m) for σ1, a viscous force
// of 5 % of F_c at the top speed for σ2).
struct LugreIdentifiable {
  bool Fc_N = true, Fs_N = true, vs_mm_s = true;
  bool sigma0_N_per_um = true, sigma1_N_s_per_mm = true, sigma2_N_s_per_mm = true;
};

struct FeedDriveResult {
  std::string axis;
  std::size_t samples = 0, steady_samples = 0, reversals = 0;
  double coulomb_N = 0.0, coulomb_sigma_N = 0.0;
  double viscous_N_s_per_mm = 0.0, viscous_sigma_N_s_per_mm = 0.0;
  double offset_N = 0.0, slope_N_per_mm = 0.0;
  double moving_mass_kg = 0.0;  // the force's part in proportion to the acceleration
  double residual_rms_N = 0.0;
  std::vector<Ripple> ripple;
  std::optional<LugreParameters> lugre, lugre_sigma;
  LugreIdentifiable lugre_identifiable;  // with `lugre`
  double lugre_residual_rms_N = 0.0;
  // The Lorentzian form's χ² (2 a fitted parameter added) less the exponential's: below −9 the
  // Lorentzian fits clearly better, above 9 the exponential; between them the two fit
  // comparably (`lugre_forms_comparable`) and the σ of the LuGre values cover both.
  double lugre_form_delta_chi2 = 0.0;
  bool lugre_forms_comparable = false;
  // Why LuGre was not fitted, when it was not; which parameters it leaves undetermined, why,
  // and the test that would determine them, when it was.
  std::string lugre_note;
  std::optional<double> stick_motion_um;
};

}  // namespace km::servo
