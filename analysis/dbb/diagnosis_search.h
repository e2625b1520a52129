// Shape searches of the DBB diagnosis (diagnosis.h): the width and decay of a reversal spike and
// the period of a stick-slip sawtooth, each chosen by the residual-sum-of-squares reduction of
// its signature conditional on a fixed base fit (diagnosis_fit.h). Internal to analysis/dbb.
#pragma once

#include <array>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "analysis/dbb/diagnosis_fit.h"

namespace km::dbb::diag {

// Samples ordered (in buckets of π/kBuckets) by the angle φ travelled since the last reversal
// of one axis, with the spike signature's factor c = signature / decay (the side −sign(v_a) and
// the radial projection n_a, from the registry model reversal_spike.h), so a spike of any width
// and decay is c·Decay(φ) over the samples where the decay is not negligible.
struct ReversalOrder {
  static constexpr int kBuckets = 2048;
  struct Entry {
    double phi;
    int sample;
    double factor;
  };
  std::vector<Entry> by_phi;
  static int Bucket(double phi);
};
// Only the samples within max_phi (rad) of the reversal are kept: a spike search over widths up
// to hi degrees reads those within SpikeMaxReach(hi).
ReversalOrder MakeReversalOrder(const Problem& p, serial_effects::EffectId id, double max_phi);
double SpikeMaxReach(double hi_deg);

// A spike shape with its residual-sum-of-squares reduction against the base and its height
// there (the spike's coefficient in the fit of base + spike, µm).
struct SpikeShape {
  double width = 0.0;
  double exponent = 1.0;
  double gain = -1.0;
  double height = 0.0;
};
// The better decay shape and the best of the other one.
struct SpikeFit {
  SpikeShape best;
  SpikeShape other;
};

// Width (and decay shape) of the spike that most reduces the residual of the base:
// log-spaced scan of `grid` widths over [lo, hi] for each decay shape, then golden section
// between the neighbours of the best. Both shapes have one height and one width, so the larger
// reduction is the larger likelihood.
SpikeFit SearchSpike(const Problem& p, const ReversalOrder& o, const Base& b, double lo, double hi,
                     int grid);

// The same refined near known widths: for each decay shape a golden section over [w/f, w·f]
// (f = kSpikeRefineFactor) about its width `widths[shape]` (shape 0 exponential, 1 Gaussian-like),
// within [lo, hi] degrees, the start kept when nothing near it is better. After the search over
// the whole range, a spike's width moves by much less than that when other effects join or
// leave the model, and only the samples near the reversals are then read.
inline constexpr double kSpikeRefineFactor = 1.8;
SpikeFit RefineSpike(const Problem& p, const ReversalOrder& o, const Base& b,
                     const std::array<double, 2>& widths, double lo, double hi);

// Variance to add to the height of `f.best` for the doubt about its decay shape: the other
// shape's probability (likelihood ratio exp(−Δ/2σ²), Δ the difference of the reductions, equal
// priors) times the squared difference of the two heights. `s2` is the noise variance.
double ShapeDoubtVariance(const SpikeFit& f, double s2);

// Samples in the low-speed zones of stick_slip.h with the angle since their axis reversed
// (degrees) and the sign and radial factor of the sawtooth there, −sign(v_a)·n_a.
struct StickZones {
  std::vector<int> idx;
  std::vector<double> phi_deg;
  std::vector<double> weight;
};
StickZones MakeStickZones(const Problem& p);

// Period (degrees) of the strongest sawtooth fundamental in the residual over the angle since
// the reversal: binned (δ = pmin/4), zero-padded DFT, parabolic peak interpolation; 0 if none.
// `chi2` receives the peak's projection energy over s2 Σ w² (≈ χ² with 2 degrees of freedom
// per frequency for white noise of variance s2).
double StickPeriodPeak(const StickZones& z, const Eigen::VectorXd& r, double pmin, double pmax,
                       double s2, double* chi2);

// The best few local maxima of the sawtooth projection within ±4 fringes of `period`.
std::vector<double> FineStickPeriods(const StickZones& z, const Eigen::VectorXd& r, double period);

// Periods commensurate with the sample step, P = step·n/m (m ≤ 4), within [lo, hi].
std::vector<double> CommensuratePeriods(double lo, double hi, double step);

// Exact refinement of a stick-slip period: golden section of the gain within ±half (degrees),
// then snapped to a commensurate period within half a sample step of phase. Returns the
// period and its gain.
std::pair<double, double> RefineStickPeriod(const Problem& p, const StickZones& z, const Base& b,
                                            double period, double half, double step, Sparse& buf);

// A commensurate period near the best one found, kept when it explains at least 90 % of what
// the best one explains on the same samples (see diagnosis_search.cpp).
std::pair<double, double> PreferCommensurate(const Problem& p, const StickZones& z, const Base& b,
                                             std::pair<double, double> best, double window,
                                             double step, Sparse& buf);

}  // namespace km::dbb::diag
