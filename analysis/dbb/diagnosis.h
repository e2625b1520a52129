// Named error diagnosis of a serial (3-axis) machine from DBB circular tests (docs/formats.md §4).
//
// Data: one evaluated turn per direction (one trace, or a cw + ccw pair of one test_id),
// y_t(θ) = in-plane radial deviation about the nominal centre (bar deviation × R_DBB / R).
// Model (linear least squares, all traces jointly):
//
//   y_t(θ) = c_u,t cos θ + c_v,t sin θ + ρ_t                           (set-up: centre, radius)
//          + Σ_k Σ_j x_kj · s_kj(θ; s_t, V_t, R_t, shape_k)  + noise
//
// s_kj = radial signature of the registry effect k (analysis/effects, e(θ) projected on the
// radial direction) for the trace's direction s_t, feed V_t and radius R_t. Shape parameters
// that are not linear are FITTED:
//  * reversal spikes: the width w (decay constant of an exponential decay exp(−φ/w), standard
//    width of a Gaussian-like decay exp(−φ²/2w²); reversal_spike.h) is a free parameter: the
//    residual sum of squares is profiled over w (variable projection: every linear parameter
//    refitted at each w; a log-spaced scan over [spike_min_width_deg, spike_max_width_deg],
//    the lower end raised to half the median sample step, then golden section), for both decay
//    shapes; the shape of larger likelihood (the smaller residual: both have one height and one
//    width) is reported (spike_shape), and the doubt about it is added to the height's variance
//    (diagnosis_search.h ShapeDoubtVariance). Widths are refitted jointly with everything else
//    once the model is complete, and once more against the named effects before the final fit.
//    A spike narrower than 1.5 median sample steps is not named (its height is not determined
//    by the samples) but listed as not identifiable. Samples ON an axis reversal are left out
//    (signatures.h StackTraces): which side of the jump they show is a matter of rounding;
//  * a cyclic period is the peak of a periodogram of the residual over the axis position
//    (binned, zero-padded DFT, parabolic peak interpolation), accepted when its projection
//    energy exceeds χ² = 40 noise variances, then refined by one backfitting step (golden
//    section on the partial residual);
//  * stick_slip (stick_slip.h: a sawtooth of amplitude A and period P in the low-speed zones
//    near the axis reversals) is a fitted signature like the others: its period is the peak of
//    a periodogram of the residual over the angle since the reversal (zone samples only), refined
//    by golden section on the exact registry signature, and the sawtooth is tried as a candidate
//    when its projection exceeds stick_slip_detection_chi2 noise variances; it is then fitted
//    jointly and named by the same test as every effect (and only with a positive amplitude:
//    reversed, the sawtooth is not stick-slip). It is not assessed when the median sample step
//    exceeds stick_slip_max_step_deg (teeth shorter than three samples alias into longer,
//    reversed ones); it is then listed as not identifiable.
// The standard uncertainty of every value and fitted shape parameter comes from the jacobian of
// the full model with respect to the linear parameters AND the fitted widths and periods
// (∂s/∂w by automatic differentiation of the registry model), so a value's uncertainty
// includes what the freedom of its shape costs.
// Every form signature is made orthogonal, per trace, to that trace's set-up columns
// {cos θ, sin θ, 1}, so the set-up terms equal the (linearised) least-squares circle of each
// trace and the form effects explain only what the circularity sees; the reported centre offset
// and radius change are the set-up terms net of the mean and first-harmonic content of the named
// effects' own signatures. How an effect looks in the two directions is what tells them apart
// (servo_mismatch flips sign between cw and ccw, squareness does not; backlash is a step,
// reversal spikes decay, lateral play bulges the quadrants; …). Effects whose signature is
// (almost) a combination of earlier ones in the list order — e.g. servo_mismatch vs squareness
// on a single trace — are reported as not identifiable rather than guessed; so are effects
// whose signature over the evaluated samples is (almost) all centre offset and radius (e.g. the
// lateral play of an axis that reverses at the two ends of a 180° partial arc).
//
// Values: docs/formats.md §4 units and signs (registry Value()); standard uncertainty σ from the
// least-squares covariance σ²(JᵀJ)⁻¹ with σ² = RSS / (N − p), propagated through the value
// jacobian. Contribution of effect k to the circularity of trace t: its own peak-to-valley
// P_k,t = range(ŝ_k,t) as a share of Σ_j P_j,t + range(unexplained residual on t), in % — always
// ≥ 0 even when effects partly cancel, and the shares plus the unexplained part make 100 %
// (set-up terms contribute 0). An effect is NAMED when |value| > z·σ (z = 3 for one-value
// effects with a fixed shape, z + 1 for two-value effects and for effects whose shape was
// searched: reversal spikes, stick_slip) and its contribution reaches the threshold in at least
// one trace; the named effects are refitted alone and ranked by contribution.
// Partial arcs (circular_test.h) are diagnosed over the arc with the same rules.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/dbb_types.h"
#include "analysis/effects/registry.h"

namespace km::dbb {

struct DiagnosisTrace {
  Direction direction = Direction::kCcw;
  double radius_mm = 150.0;
  double feed_mm_min = 1000.0;
  std::vector<double> angle_rad;
  std::vector<double> dev_um;  // in-plane radial deviation about the nominal centre
  // Optional cos and sin of angle_rad (computed when absent).
  std::vector<double> cos_angle;
  std::vector<double> sin_angle;
};

// Trace of a test from its analysed figures (deviation about the nominal centre, scaled by
// R_DBB / R to the in-plane radial error of the machine).
DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result);
// Same, with the deviation about the nominal centre already computed
// (DeviationAboutNominalCentre(result)).
DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result,
                                  const std::vector<double>& dev_about_nominal_um);

struct DiagnosisOptions {
  double significance = 3.0;  // z for one-value effects (z + 1: two values, searched shape)
  double min_contribution_pct = 2.0;
  double confound_ratio = 0.1;       // part of a signature left after projecting out earlier ones
  double spike_min_width_deg = 0.1;  // raised to half the median sample step
  double spike_max_width_deg = 8.0;
  double cyclic_min_period_mm = 1.0;
  double cyclic_max_period_fraction = 1.0 / 3.0;  // of the radius
  double cyclic_detection_chi2 = 40.0;            // projection energy / σ² needed to try a period
  double stick_slip_min_period_deg = 0.2;         // raised to 3 median sample steps
  double stick_slip_max_period_deg = 2.0;
  double stick_slip_max_step_deg = 0.2;     // coarser sampling: stick_slip not assessed
  double stick_slip_detection_chi2 = 30.0;  // projection energy / σ² needed to try a sawtooth
  bool search_cyclic = true;
  // Threads for independent parts (the fixed-shape signatures, the two axes' spike and cyclic
  // searches): 0 = the machine's cores, 1 = in order. The result is the same.
  unsigned threads = 0;
  void Check() const;  // throws km::InvalidInput on nonsense
};

struct DiagnosisEntry {
  effects::EffectId id = effects::EffectId::kCentreOffset;
  std::string effect;  // contract name for the plane
  std::string unit;
  std::vector<double> value;              // one value, or [u, v] for centre_offset
  std::vector<double> uncertainty;        // standard uncertainty of each value
  std::vector<double> contribution_pct;   // per trace, input order
  std::vector<double> peak_to_valley_um;  // per trace: range of the effect's own signature
  double significance = 0.0;              // |value| / uncertainty (norm for two values)
  std::map<std::string, double> shape;    // shape parameters, e.g. period_mm, width_deg (and
                                          // for spikes width_s, the width in seconds)
  std::map<std::string, double> shape_uncertainty;  // of the fitted shape parameters
  std::string shape_kind;                           // reversal spikes: "exponential" or "gaussian"
  std::vector<double> params;                       // all model parameters
  bool named = false;
  double MaxContribution() const;
};

struct DiagnosisResult {
  std::vector<DiagnosisEntry> named;          // significant effects, ranked
  std::vector<DiagnosisEntry> candidates;     // every estimated effect (named or not)
  std::vector<std::string> not_identifiable;  // "effect (confounded with other)"
  double residual_rms_um = 0.0;               // after the final model
  double noise_um = 0.0;                      // σ from successive differences of the residual
  // Per trace: fitted form signature sum at the samples the diagnosis used (those on an axis
  // reversal are left out).
  std::vector<std::vector<double>> form_model_um;
};

DiagnosisResult DiagnoseSerialDbb(const std::vector<DiagnosisTrace>& traces, Plane plane,
                                  const DiagnosisOptions& options = {});

// Axis letters of a plane (first, second), e.g. XY → ('x', 'y').
std::pair<char, char> AxisLetters(Plane plane);

}  // namespace km::dbb
