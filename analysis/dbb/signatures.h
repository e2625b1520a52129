// Radial signatures of the serial-machine error effects over a set of DBB traces, free of the
// set-up terms — the shared design-matrix builder of the diagnosis (diagnosis.h) and the
// discovery ladder (discovery.h).
//
// Traces t = 1…T are stacked into one sample vector y (in-plane radial deviation about the
// nominal centre, µm). Each trace has its own set-up columns S_t = {cos θ, sin θ, 1} (centre
// offset and radius change: the linearised least-squares circle, [PM-600 report] eq. 2.6). A
// registry effect k with fixed shape parameters contributes the columns s_kj(θ; s_t, V_t, R_t) =
// ∂Δr/∂p_j of its linear parameters (serial_effects::RadialBasis). RemoveSetup projects a column on
// the orthogonal complement of the set-up columns, trace by trace:
//
//   c ← c − S_t (S_tᵀ S_t)⁻¹ S_tᵀ c,
//
// so a least-squares fit of set-up-free columns to the set-up-free data equals the joint fit
// with the set-up terms, and the removed coefficients (the effect's own centre/radius part) are
// kept to give the set-up values back net of the named effects.
//
// Also here: the successive-difference noise estimate σ = rms(Δr)/√2 of a residual, and the
// cyclic-period search of a residual over the axis position (binned periodogram, projection
// energy, golden-section refinement) used to choose the period shape parameter.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "analysis/dbb/diagnosis_types.h"
#include "analysis/serial_effects/registry.h"

namespace km::dbb {

inline constexpr int kCyclicBins = 1024;  // bins of the axis position for the periodogram
inline constexpr int kCyclicFft = 8192;   // zero-padded transform length

struct SignatureSample {
  serial_effects::Angle<double> a;
  int trace = 0;
};

// Stacked traces with their set-up columns {cos θ, sin θ, 1} per trace.
struct StackedTraces {
  std::vector<SignatureSample> samples;
  std::vector<std::size_t> begin;  // first sample of each trace (plus end)
  std::vector<serial_effects::EffectContext> ctx;
  std::vector<Eigen::Matrix3d> setup_inv;  // (S_tᵀ S_t)⁻¹
  Eigen::VectorXd cos_a, sin_a, theta;     // cos θ, sin θ, θ of the samples (contiguous)
  Eigen::VectorXd ones;                    // 1 per sample (sums as inner products)
  Eigen::VectorXd y;
  int n = 0;
  int traces = 0;
  // Optional (ComputeReversalPhases): for each axis, every sample's angle since that axis
  // reversed and the side after it (serial_effects::ReversalSpike::Phase), read by the spike
  // signatures and the diagnosis' reversal orders instead of evaluating the phase again.
  struct ReversalPhases {
    std::vector<double> phi;
    std::vector<double> side;
  };
  std::array<ReversalPhases, 2> reversal_phase;
  void ComputeReversalPhases();

  // Removes from `col` its least-squares projection on each trace's set-up columns; returns
  // the set-up coefficients of trace t in coef (3 per trace) when wanted.
  void RemoveSetup(Eigen::VectorXd& col, std::vector<Eigen::Vector3d>* coef = nullptr) const;
  // The same for the rows of trace t only; returns its set-up coefficients.
  Eigen::Vector3d RemoveSetupOfTrace(Eigen::VectorXd& col, int t) const;
};

// Validates and stacks the traces (≥ 16 samples each, positive radius, going around the
// circle); throws km::InvalidInput otherwise. With `leave_out_reversals`, samples at an axis
// reversal itself (serial_effects::internal::AtAxisReversal) are not stacked: there a reversal
// spike jumps from nothing to its height and a backlash from one side to the other, and which value
// such a sample shows depends on how the instant of the reversal was rounded (by the control's
// interpolation, the logger, a simulation), not on the machine.
StackedTraces StackTraces(const std::vector<DiagnosisTrace>& traces,
                          bool leave_out_reversals = false);

// Set-up-free radial signature columns of one effect with fixed shape parameters (missing
// trailing ones: the registry defaults, also in the returned shape) and the set-up part removed
// from each column (per trace).
struct EffectColumns {
  serial_effects::EffectId id = serial_effects::EffectId::kSquareness;
  std::vector<double> shape;
  std::vector<Eigen::VectorXd> cols;                     // one per linear parameter
  std::vector<std::vector<Eigen::Vector3d>> setup_part;  // [column][trace]
};
EffectColumns SetupFreeSignature(const StackedTraces& p, serial_effects::EffectId id,
                                 std::vector<double> shape);
// The same in parts, e.g. the traces on several threads: SignatureShell gives the columns
// (sized, not yet computed) with the shape completed, SignatureOfTrace fills the rows of trace t
// and its set-up part. Shell plus every trace equals SetupFreeSignature.
EffectColumns SignatureShell(const StackedTraces& p, serial_effects::EffectId id,
                             std::vector<double> shape);
void SignatureOfTrace(const StackedTraces& p, int t, EffectColumns& c);

// σ from successive differences of r within each trace: sqrt(Σ Δ² / (2·count)).
double DiffNoiseUm(const StackedTraces& p, const Eigen::VectorXd& r);

// Periodogram of the residual against a cyclic error of axis `axis`: bins the numerator
// Σ r·n_a over the axis position and transforms it; returns the period of the strongest peak
// in [pmin, pmax] mm (0 if none).
double CyclicPeriodPeak(const StackedTraces& p, const Eigen::VectorXd& r, int axis, double pmin,
                        double pmax);
// Power spectrum |X_k|², k = 0 … (len − 1)/2, of the real sequence x (len = x.size()), from
// OpenCV's packed real transform (no complex output buffer is built).
std::vector<double> RealPowerSpectrum(std::vector<double> x);

// Energy of the residual's projection on a cyclic error of period `period` (axis `axis`),
// using every `stride`-th sample.
double CyclicEnergy(const StackedTraces& p, const Eigen::VectorXd& r, int axis, double period,
                    int stride);
// Golden-section refinement of the periodogram peak within ±rel of `period`.
double RefinePeriod(const StackedTraces& p, const Eigen::VectorXd& r, int axis, double period,
                    double rel, double spacing_mm);

// Value of a fitted effect in its reported unit (registry Value()) with its standard
// uncertainty, propagated from the covariance of its linear parameters through the value
// jacobian, and z = |value| / RMS(σ) (finite for noise-free data). The linear parameters are
// x[off, off + num_linear) with covariance cov.block(off, off, …); `shape` completes them.
struct EffectEstimate {
  std::vector<double> params;  // all model parameters (linear, then shape)
  std::vector<double> value;
  std::vector<double> sigma;
  double z = 0.0;
};
EffectEstimate EstimateEffect(const StackedTraces& p, serial_effects::EffectId id,
                              const std::vector<double>& shape, const Eigen::VectorXd& x,
                              const Eigen::MatrixXd& cov, int off);

// Set-up terms over the traces: the mean centre offset (u, v) and radius change, and their
// variances for a residual variance sigma2 (each trace's least-squares circle, averaged).
struct SetupMean {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d var = Eigen::Vector3d::Zero();
};
SetupMean MeanSetup(const StackedTraces& p, const std::vector<Eigen::Vector3d>& setup,
                    double sigma2);

// Gives back to the set-up terms what the set-up fit absorbed of a fitted effect's column
// (its mean and first harmonic): setup[t] −= coefficient · part[t].
void NetSetup(std::vector<Eigen::Vector3d>& setup, double coefficient,
              const std::vector<Eigen::Vector3d>& part);

}  // namespace km::dbb
