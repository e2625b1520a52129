// Steps of the feed-drive analysis (feed_drive.h): strokes collected from the records, the
// steady-motion fit with the position-dependent ripple, the LuGre fit at reversals.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/servo/feed_drive_types.h"
#include "analysis/servo/servo_types.h"

namespace km::servo::detail {

struct Strokes {
  std::vector<double> t, x, v, a, f;     // every record, one after the other (a in mm/s²)
  std::vector<double> a_change;          // spread of a over the sample and its neighbours
  std::vector<std::size_t> segment_end;  // one past the last sample of each record
  std::vector<bool> steady;              // used by the steady-motion fit
  std::vector<std::size_t> stroke;       // the stroke of each sample, counted over the records
  std::vector<double> stroke_top;        // the top speed of each stroke (mm/s), 0 if standing
  std::vector<std::size_t> reversals;    // first sample after each change of direction
  std::vector<double> position_part;     // c0 + c1 x + ripple(x), after FitSteady
  std::vector<double> known;             // force explained beforehand (Stribeck), or empty
  double noise_N = 0.0;                  // force noise of one sample, after FitSteady
  double steady_mass_kg = 0.0;           // the moving mass of FitSteady (weights)
  std::vector<double> ripple_periods;    // every component FitSteady kept in the fit
  std::size_t SegmentOf(std::size_t i) const;
  // Weight of sample i in the fits: 1 / (1 + (uncertainty of its inertia / noise)²), the
  // inertia uncertain by half the change of the acceleration around it (where a speed ramp
  // starts or ends between samples the second difference mixes both sides).
  double Weight(std::size_t i, double mass_kg) const;
  double Known(std::size_t i) const { return known.empty() ? 0.0 : known[i]; }
};

Strokes CollectStrokes(const std::vector<const ServoFile*>& files, const std::string& axis,
                       const FeedDriveOptions& o);
// A sinusoid a cos(2πx/P) + b sin(2πx/P) of the position-dependent part.
struct RippleComponent {
  double period = 0.0, a = 0.0, b = 0.0;
};
// Dominant periods of the position-dependent part binned at the bin centres `xc` (values `y`):
// periodogram over a geometric grid of periods in [pmin, pmax], refined by Brent's method,
// subtracted, repeated while significant (feed_drive_periods.cpp).
std::vector<RippleComponent> FindPeriods(const std::vector<double>& xc, std::vector<double> y,
                                         double pmin, double pmax, int max_components);
// FindPeriods' periodogram: at each of `periods`, the residual sum of squares of the best
// sinusoid of that period with a constant through the bins.
std::vector<double> PeriodogramOf(const std::vector<double>& xc, const std::vector<double>& y,
                                  const std::vector<double>& periods);
// Steady fit; `r` gets Coulomb, viscous, mass, offset, slope, ripple; `s` the position part,
// the noise and (through the mass) the weights.
void FitSteady(Strokes& s, const FeedDriveOptions& o, FeedDriveResult& r);
// The samples of one reversal fitted by LuGre (inclusive).
struct Window {
  std::size_t first = 0, last = 0;
};
// How the speed runs between two samples, of which the data give the positions and (by central
// differences) the speeds: linear, parallel to the line through both speeds and with the
// measured travel, the sample's speed its central difference; or constant at the interval's
// mean, also at the sample that ends it. The model is fitted with the first; the change under
// the second is part of the uncertainty (they differ where the reversal passes between few
// samples, or a speed ramp starts or ends between them).
enum class Reading { kLinear, kConstant };
constexpr int kSubsteps = 8;  // of one sample interval, for linear speed
// The derivatives of the bristle force in ln F_s, ln v_s, ln σ0 and ln δ.
constexpr int kBristleParams = 4;
using BristleDerivatives = std::array<double, kBristleParams>;
// σ0 z + σ1 dz/dt at every sample of the windows (one after the other), each window starting in
// steady sliding; z integrated in exact steps of eq. 4.1 over sub-intervals of constant speed
// (feed_drive_bristles.cpp). `damping` (when given) gets the force per unit σ1, 10⁻³ dz/dt (z
// does not depend on σ1); `derivatives` (when given) the force's derivatives, that in ln δ only
// when `exponent` (0 otherwise).
void BristleForce(const Strokes& s, const std::vector<Window>& ws, const LugreParameters& p,
                  Reading reading, std::vector<double>& out, std::vector<double>* damping = nullptr,
                  std::vector<BristleDerivatives>* derivatives = nullptr, bool exponent = false);
// The motion of the windows as BristleForce integrates it (its steps of constant speed, the
// speeds the samples are read at), which depends on the records and the reading only: formed
// once for the many evaluations of a fit.
class BristlePath {
 public:
  BristlePath(const Strokes& s, const std::vector<Window>& ws, Reading reading);
  ~BristlePath();
  BristlePath(const BristlePath&) = delete;
  BristlePath& operator=(const BristlePath&) = delete;
  struct Motions;
  const Motions& motions() const { return *motions_; }

 private:
  std::unique_ptr<Motions> motions_;
};
// BristleForce along a path formed beforehand (of the same records, windows and reading).
void BristleForce(const Strokes& s, const std::vector<Window>& ws, const BristlePath& path,
                  const LugreParameters& p, std::vector<double>& out, std::vector<double>* damping,
                  std::vector<BristleDerivatives>* derivatives, bool exponent);
// Whether BristleForce and FindPeriods may take their four-lane paths where the processor has
// AVX2 (the default; bit for bit the other paths, which the tests compare them with).
void UseFeedDriveAvx2(bool on);
bool FeedDriveAvx2Allowed();
// What a LuGre fit leaves for comparing the forms of the Stribeck rise and for judging which
// parameters the reversals determine.
struct LugreFit {
  double rss = INFINITY;    // the weighted residual
  double s2 = 0.0;          // the noise of one sample, its correlation included
  int params = 0;           // fitted (4, or 5 with δ)
  double transition = 0.0;  // samples a reversal while the friction changes sides (median)
  double slow = 0.0;        // samples a reversal slower than 2 v_s (median)
  double top_speed = 0.0;   // of the steady strokes
};
// Counts the samples of `fit` for r.lugre (y is the windows' bristle force: the force less
// everything else; top_speed the strokes' top speed).
void JudgeLugre(const Strokes& s, const std::vector<Window>& ws, const std::vector<double>& y,
                double top_speed, const FeedDriveResult& r, LugreFit& fit);
// Flags the parameters of r.lugre that the reversals leave undetermined (σ and the counts of
// `fit`) and says in r.lugre_note why and which test would determine them.
void DecideLugre(const LugreFit& fit, FeedDriveResult& r);

// LuGre at the reversals with the rise of form `form`, from `start` (a fit of the same
// reversals) or from several starts; `info` (when given) gets what the comparison of the forms
// needs.
void FitLugre(const Strokes& s, const FeedDriveOptions& o, FeedDriveResult& r,
              const LugreParameters* start = nullptr,
              LugreParameters::Form form = LugreParameters::Form::kExponential,
              LugreFit* info = nullptr);
// How Coulomb and viscous friction of FitSteady change when the known part of every sample
// grows by each of `deltas` (the fit's columns held, its ripple periods fixed): one normal
// matrix for all of them.
std::vector<Eigen::Vector2d> SteadyShifts(const Strokes& s,
                                          const std::vector<std::vector<double>>& deltas);
// g(v) = F_c + (F_s − F_c) exp(−|v/v_s|^δ), the steady sliding friction at speed v.
double StribeckG(const LugreParameters& p, double v);
// The Stribeck rise sign(v) (F_s − F_c) exp(−|v/v_s|^δ) at speed v.
double StribeckRise(const LugreParameters& p, double v);
// Sets s.known to the Stribeck rise sign(v) (F_s − F_c) exp(−|v/v_s|^δ) of every sample; true
// when it exceeds a thousandth of the noise at some steady sample.
bool SetStribeck(Strokes& s, const LugreParameters& p);

}  // namespace km::servo::detail
