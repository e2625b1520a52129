// Discovery of the physical error effects of a serial (3-axis) machine from DBB circular tests:
// forward stepwise model building, each step one named effect of the registry (docs/formats.md §3
// `kinemetric discover`, §4 names / units / signs).
//
// Data y = in-plane radial deviation about the nominal centre of every trace (cw and ccw, any
// feeds; diagnosis.h MakeDiagnosisTrace), stacked. Model 0 = the nominal machine: per trace the
// set-up terms {cos θ, sin θ, 1} (centre offset and radius: the least-squares circle, [PM-600
// report] eq. 2.6). The gap g = y − model. Every candidate effect k (linear parameters x_k, shape
// fixed as in the diagnosis: reversal-spike width from a small set, cyclic period from the
// periodogram of the current gap) has set-up-free signature columns A_k (signatures.h). For a
// model M with columns A_M, step m tries every candidate k ∉ M:
//
//   RSS(M ∪ k) = RSS(M) − ‖Q_kᵀ g‖²,   Q_k = orthonormal basis of (I − P_M) A_k,
//
// and adds the k with the largest drop, if
//   • identifiable: every column of A_k keeps ≥ confound_ratio² of its squared norm after
//     projection on the model's columns (and its own earlier columns) — the diagnosis rule; when
//     another candidate cannot be told apart from it given the model (same rule between the two
//     projected signatures), the earlier one in the registry list order is taken and the other
//     is named in the evidence (e.g. servo_mismatch vs squareness on a single trace);
//   • significant: the nested-model F-test
//       F = ((RSS_M − RSS_{M∪k}) / q) / (RSS_{M∪k} / (N − 3T − p)),  q = columns of k,
//     p = model columns after the step, T = traces, has p-value P(F_{q, N−3T−p} > F) < p_max
//     (regularised incomplete beta function, continued fraction), and the joint refit gives
//     |value| > z·σ (z + 1 for two-value effects; σ from σ²(AᵀA)⁻¹, σ² = RSS/(N − 3T − p),
//     propagated through the registry's value jacobian). A searched shape (spike width, cyclic
//     period over ~10³ periodogram bins) makes the F-test optimistic by at most that number of
//     tries; the 1e-6 level keeps the family-wise false-alarm rate below ~1e-3 per step.
// It stops at the first rejected step, when no candidate is left, or when the gap RMS is
// within noise_stop_fraction of the noise floor. For that test the floor is taken ≥ the data
// resolution and ≥ the second-order term of the bar length, max|g₀|² / (2R) (the signatures
// are first order in e/R), so that noise-free synthetic data do not chase rounding and geometry.
//
// Noise floor: white-noise σ of the gap from successive differences inside each trace, with a
// robust scale: σ = 1.4826 · MAD(Δg) / √2. For white noise Δg ~ N(0, 2σ²); smooth unmodelled
// effects change Δg by (slope × sample spacing), negligible at DBB sampling (0.1° → < 0.03 µm
// for a 10 µm second harmonic), and the few large differences at steps (backlash) or spikes
// do not move a median — so the floor is what no smooth model can explain, independent of
// which effects the ladder adds. When the model is complete, the gap RMS ≈ noise floor.
//
// Final model: the joint refit of the accepted effects with the set-up terms; centre offset and
// radius change are reported net of the accepted effects' own mean and first harmonic (as the
// diagnosis does). servo_lag (a per-trace constant) is absorbed by the set-up radius and
// stick_slip (random phase) is not a linear signature; neither is a candidate here.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "analysis/dbb/dbb_types.h"
#include "analysis/dbb/diagnosis.h"
#include "analysis/effects/registry.h"

namespace km::dbb {

struct DiscoveryOptions {
  double max_p_value = 1e-6;          // F-test level to accept a step
  double significance = 3.0;          // z for one-value effects (z + 1 for two-value effects)
  double confound_ratio = 0.1;        // part of a signature left after projecting out the model
  double noise_stop_fraction = 0.05;  // stop when gap RMS ≤ (1 + this) × noise floor
  double resolution_um = 1e-6;        // data resolution (file: 6 decimals); floor ≥ this
  std::vector<double> spike_widths_deg = {0.5, 1.0, 2.0, 4.0};
  double cyclic_min_period_mm = 1.0;
  double cyclic_max_period_fraction = 1.0 / 3.0;  // of the radius
  bool search_cyclic = true;
  int max_steps = 16;
  void Check() const;  // throws km::InvalidInput on nonsense
};

struct DiscoveryEvidence {
  double rss_before_um2 = 0.0;
  double rss_after_um2 = 0.0;
  double f_statistic = 0.0;
  double p_value = 1.0;
  double log10_p_value = 0.0;  // finite also when p_value underflows to 0
  int df_numerator = 0;
  int df_denominator = 0;
  std::vector<double> value;  // docs/formats.md §4 value(s) of the added effect in the joint refit
  std::vector<double> sigma;  // standard uncertainty of each value
  std::string unit;
  double z_score = 0.0;                      // |value| / σ (norm for several values)
  std::map<std::string, double> parameters;  // all model parameters (linear and shape)
  std::string runner_up;                     // best other effect at this step ("" if none)
  double runner_up_rss_drop_um2 = 0.0;
  std::vector<std::string> indistinguishable_from;  // candidates confounded with this one
};

struct DiscoveryStep {
  effects::EffectId id = effects::EffectId::kSquareness;
  std::string added_effect;
  DiscoveryEvidence evidence;
  double gap_rms_before_um = 0.0;
  double gap_rms_after_um = 0.0;
};

struct DiscoveryModelEntry {
  effects::EffectId id = effects::EffectId::kCentreOffset;
  std::string effect;
  std::vector<double> value;
  std::vector<double> sigma;
  std::string unit;
  std::map<std::string, double> shape;  // fixed shape parameters, e.g. width_deg, period_mm
};

struct DiscoveryResult {
  std::vector<DiscoveryStep> steps;
  std::vector<DiscoveryModelEntry> final_model;  // set-up terms first, then the steps' effects
  double unexplained_rms_um = 0.0;               // RMS of the final gap
  double noise_floor_um = 0.0;
  std::string stop_reason;                    // why the ladder stopped
  std::vector<std::string> rejected;          // the best candidate that failed, with the rule
  std::vector<std::string> not_identifiable;  // "effect (confounded with other)" at the stop
};

DiscoveryResult DiscoverSerialDbb(const std::vector<DiagnosisTrace>& traces, Plane plane,
                                  const DiscoveryOptions& options = {});

// Regularised incomplete beta function I_x(a, b), a, b > 0, 0 ≤ x ≤ 1 (continued fraction,
// modified Lentz; symmetry I_x(a, b) = 1 − I_{1−x}(b, a) where it converges faster).
double RegularisedIncompleteBeta(double a, double b, double x);
// Natural log of the upper tail P(F_{d1,d2} > f) = I_{d2/(d2 + d1 f)}(d2/2, d1/2).
double LogFUpperTail(double f, double d1, double d2);
// Robust white-noise σ of a stacked residual (see above): 1.4826 · MAD(Δ) / √2 per trace pool.
double RobustDiffNoiseUm(const std::vector<std::vector<double>>& residual_per_trace);

}  // namespace km::dbb
