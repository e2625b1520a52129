// Named error diagnosis of a serial (3-axis) machine from DBB circular tests (contract §4).
//
// Data: one evaluated turn per direction (one trace, or a cw + ccw pair of one test_id),
// y_t(θ) = in-plane radial deviation about the nominal centre (bar deviation × R_DBB / R).
// Model (linear least squares, all traces jointly):
//
//   y_t(θ) = c_u,t cos θ + c_v,t sin θ + ρ_t                           (set-up: centre, radius)
//          + Σ_k Σ_j x_kj · s_kj(θ; s_t, V_t, R_t, shape_k)  + noise
//
// s_kj = radial signature of the registry effect k (analysis/effects, e(θ) projected on the
// radial direction) for the trace's direction s_t, feed V_t and radius R_t, with the effect's
// shape parameters fixed: the reversal-spike width is the one of a small set that most
// reduces the residual sum of squares of the stage-1 model; a cyclic period is the peak of a
// periodogram of the residual over the axis position (binned, zero-padded DFT, parabolic peak
// interpolation), accepted when its projection energy exceeds χ² = 40 noise variances, then
// refined by one backfitting step (golden section on the partial residual). Every form
// signature is made orthogonal, per trace, to that trace's set-up columns {cos θ, sin θ, 1}, so the
// set-up terms equal the (linearised) least-squares circle of each trace and the form effects
// explain only what the circularity sees; the reported centre offset and radius change are the
// set-up terms net of the mean and first-harmonic content of the named effects' own signatures. How
// an effect looks in the two directions is what tells them apart (servo_mismatch flips sign between
// cw and ccw, squareness does not; backlash is a step, reversal spikes decay, lateral play bulges
// the quadrants; …). Effects whose signature is (almost) a combination of earlier ones in the list
// order — e.g. servo_mismatch vs squareness on a single trace — are reported as not identifiable
// rather than guessed.
//
// Values: contract §4 units and signs (registry Value()); standard uncertainty from the
// least-squares covariance σ²(AᵀA)⁻¹ with σ² = RSS / (N − p), propagated through the value
// jacobian. Contribution of effect k to the circularity of trace t: its own peak-to-valley
// P_k,t = range(ŝ_k,t) as a share of Σ_j P_j,t + range(unexplained residual on t), in % — always
// ≥ 0 even when effects partly cancel, and the shares plus the unexplained part make 100 %
// (set-up terms contribute 0). An effect is NAMED when |value| > z·σ (z = 3 for one-value
// effects, z + 1 for two-value effects) and its contribution reaches the threshold in at least
// one trace; the named effects are refitted alone and ranked by contribution.
// stick_slip has a random phase and is not fitted: it is the excess high-frequency power of the
// residual in the low-speed zones near axis reversals over the rest (F-like test), converted
// to a sawtooth amplitude A = √(3 · excess variance) (peak-to-valley 2A). When that excess is
// significant, the fit is weighted (zone samples by the variance ratio) so the stick-slip
// scatter is not mistaken for spikes or backlash.
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
};

// Trace of a test from its analysed figures (deviation about the nominal centre, scaled by
// R_DBB / R to the in-plane radial error of the machine).
DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result);
// Same, with the deviation about the nominal centre already computed
// (DeviationAboutNominalCentre(result)).
DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result,
                                  const std::vector<double>& dev_about_nominal_um);

struct DiagnosisOptions {
  double significance = 3.0;  // z for one-value effects (z + 1 for two-value effects)
  double min_contribution_pct = 2.0;
  double confound_ratio = 0.1;  // part of a signature left after projecting out earlier ones
  std::vector<double> spike_widths_deg = {0.5, 1.0, 2.0, 4.0};
  double cyclic_min_period_mm = 1.0;
  double cyclic_max_period_fraction = 1.0 / 3.0;  // of the radius
  double cyclic_detection_chi2 = 40.0;            // projection energy / σ² needed to try a period
  double stick_slip_window_deg = 1.0;             // half width of the moving average (high-pass)
  bool search_cyclic = true;
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
  std::map<std::string, double> shape;    // fixed shape parameters, e.g. period_mm, width_deg
  std::vector<double> params;             // all model parameters
  bool named = false;
  double MaxContribution() const;
};

struct DiagnosisResult {
  std::vector<DiagnosisEntry> named;               // significant effects, ranked
  std::vector<DiagnosisEntry> candidates;          // every estimated effect (named or not)
  std::vector<std::string> not_identifiable;       // "effect (confounded with other)"
  double residual_rms_um = 0.0;                    // after the final model
  double noise_um = 0.0;                           // σ from successive differences of the residual
  std::vector<std::vector<double>> form_model_um;  // per trace: fitted form signature sum
};

DiagnosisResult DiagnoseSerialDbb(const std::vector<DiagnosisTrace>& traces, Plane plane,
                                  const DiagnosisOptions& options = {});

// Axis letters of a plane (first, second), e.g. XY → ('x', 'y').
std::pair<char, char> AxisLetters(Plane plane);

}  // namespace km::dbb
