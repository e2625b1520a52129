// ISO 230-4 figures of circular tests, computed from one evaluated turn (circular_test.h).
//
// Per trace:
//  * circular deviation G: range of the radial deviation about the least-squares circle centre
//    (= circularity_um of [PM-600 report] eq. 4.8);
//  * radial deviation F_max / F_min: deviation of the actual radius from the NOMINAL radius R,
//      centre_corrected mode: measured from the least-squares centre, F = |P − c_LS| − R;
//      absolute mode:         measured from the nominal centre (the measured fixed ball),
//                             F = bar deviation minus the nominal set-up term.
// Per cw/ccw pair (same test_id):
//  * circular hysteresis H: max |r_ccw(θ) − r_cw(θ)| with both traces taken about their
//    COMMON least-squares centre and each interpolated (linearly, periodically) onto the
//    other's angles (circular_hysteresis_um);
//  * the same with each trace about its OWN least-squares centre
//    (circular_hysteresis_own_centres_um), a second figure only;
//  * bidirectional circular deviation G(b): range of both traces together about their common
//    least-squares centre.
// Which centre H is taken about. ISO 230-4 defines H as the maximum radial difference between
// the two actual paths, one traced cw, the other ccw: a difference between two paths, so both
// are measured from ONE reference, as G(b) (two concentric circles enveloping both paths) is.
// The set-up of a ball bar (fixed-ball placement) is the same in both directions, and the
// common least-squares centre removes it once; it does not remove a shift of one path against
// the other, which is part of the difference H measures. Each trace about its own centre
// removes that shift too (a directional error not symmetric about the centre, e.g. a reversal
// error at one quadrant only, or drift between the runs, moves each trace's own centre), which
// gives a different number, not the ISO 230-4 figure; it is reported beside it, named.
// All values in µm, in the units of the results (circular_test.h: bar, or tool path — the
// units AnalyzeDbbSet reports); both results of a pair must have the same units.
//
// Partial arcs (circular_test.h, coverage.h): every figure is evaluated over the arc (the
// least-squares circle of the arc, the range over the arc), which the figures state
// (full_turn = false, evaluated_arc_deg). For a pair, H compares the traces only where both
// arcs have samples (no interpolation across the part of the circle that was not run) and the
// pair states the length of that common arc.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "analysis/dbb/circular_test.h"

namespace km::dbb {

struct Iso230Figures {
  DeviationUnits units = DeviationUnits::kBar;  // of the result the figures come from
  double circular_deviation_um = 0.0;
  double radial_deviation_max_um = 0.0;
  double radial_deviation_min_um = 0.0;
  std::string radial_reference;  // "least_squares_centre" or "nominal_centre"
  bool full_turn = true;         // false: evaluated over a partial arc
  double evaluated_arc_deg = 360.0;
};

struct Iso230PairFigures {
  DeviationUnits units = DeviationUnits::kBar;
  double circular_hysteresis_um = 0.0;              // about the common least-squares centre
  double circular_hysteresis_own_centres_um = 0.0;  // each trace about its own LS centre
  double bidirectional_circular_deviation_um = 0.0;
  std::array<double, 2> common_centre_um{};  // common least-squares centre (plane axes)
  bool full_turn = true;                     // false: at least one trace is a partial arc
  double evaluated_arc_deg = 360.0;          // arc both traces cover (H is compared there)
};

// Commanded radius R in µm recovered from a result (R0 − average radial error).
double NominalRadiusUm(const CircularTestResult& r);

// Bar deviation of each sample about the nominal centre (µm): the inverse of the planar
// representation, exact: ρ = n·c + √((n·c)² − |c|² + (R0 + e)²), deviation = ρ − R.
std::vector<double> DeviationAboutNominalCentre(const CircularTestResult& r);

Iso230Figures ComputeIso230(const CircularTestResult& r);

// `cw` and `ccw` must be the two directions of one test_id. Throws km::InvalidInput otherwise.
Iso230PairFigures ComputeIso230Pair(const CircularTestResult& cw, const CircularTestResult& ccw);
// Same, with DeviationAboutNominalCentre of both already computed; the common circle and the
// hysteresis about the own centres run at once on up to `threads` threads (same result).
Iso230PairFigures ComputeIso230Pair(const CircularTestResult& cw, const CircularTestResult& ccw,
                                    const std::vector<double>& dev_cw_um,
                                    const std::vector<double>& dev_ccw_um, unsigned threads = 1);

// What a pair's hysteresis needs of the angles alone: their orders and, for two full turns in
// rotation order (one turn in time order, the usual case), where each sample of one trace falls
// between two samples of the other and the weight of the linear interpolation there. Built once
// for a pair and reused for any deviations at the same angles (a Monte Carlo run changes only
// the deviations); ComputeIso230Pair builds and uses the same, so both give the same H.
class Iso230PairGeometry {
 public:
  // Checks the pair as ComputeIso230Pair does (km::InvalidInput).
  Iso230PairGeometry(const CircularTestResult& cw, const CircularTestResult& ccw);

  // H of two traces given by their radial values at their samples in time order (both about
  // one reference); `arc_deg` receives the arc compared. Throws km::InvalidInput when partial
  // arcs do not overlap.
  double Hysteresis(std::span<const double> vcw, std::span<const double> vccw,
                    double* arc_deg) const;

  // One query sample q of a trace against the other trace interpolated between samples i0 and
  // i1 with weight w (indices of the samples in time order).
  struct Interpolation {
    std::uint32_t q, i0, i1;
    double w;
  };

 private:
  bool full_turn_ = true;
  double mid_rad_ = 0.0;  // partial arcs: the angles unwrapped about it
  std::vector<double> cw_rad_, ccw_rad_;
  // Full turns in rotation order: the ccw samples against the cw trace and the other way.
  std::vector<Interpolation> ccw_on_cw_, cw_on_ccw_;
};

// Same as ComputeIso230Pair(cw, ccw, dev_cw_um, dev_ccw_um) with the pair's geometry built once.
Iso230PairFigures ComputeIso230Pair(const Iso230PairGeometry& geometry,
                                    const CircularTestResult& cw, const CircularTestResult& ccw,
                                    const std::vector<double>& dev_cw_um,
                                    const std::vector<double>& dev_ccw_um);

}  // namespace km::dbb
