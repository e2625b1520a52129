// Named error diagnosis of a serial (3-axis) machine from DBB circular tests (docs/formats.md §4).
//
// Data: one evaluated turn per direction (one trace, or a cw + ccw pair of one test_id),
// y_t(θ) = in-plane radial deviation about the nominal centre (bar deviation × R_DBB / R).
// Model (linear least squares, all traces jointly):
//
//   y_t(θ) = c_u,t cos θ + c_v,t sin θ + ρ_t                           (set-up: centre, radius)
//          + Σ_k Σ_j x_kj · s_kj(θ; s_t, V_t, R_t, shape_k)  + noise
//
// s_kj = radial signature of the registry effect k (analysis/serial_effects, e(θ) projected on the
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

#include <vector>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/dbb_types.h"
#include "analysis/dbb/diagnosis_types.h"

namespace km::dbb {

// Trace of a test from its analysed figures (deviation about the nominal centre, scaled by
// R_DBB / R to the in-plane radial error of the machine).
DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result);
// Same, with the deviation about the nominal centre already computed
// (DeviationAboutNominalCentre(result)).
DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result,
                                  const std::vector<double>& dev_about_nominal_um);

DiagnosisResult DiagnoseSerialDbb(const std::vector<DiagnosisTrace>& traces, Plane plane,
                                  const DiagnosisOptions& options = {});

}  // namespace km::dbb
