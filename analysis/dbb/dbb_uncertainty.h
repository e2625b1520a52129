// Uncertainty of the ISO 230-4 figures of a DBB test and of a cw/ccw pair from the ball bar's
// own uncertainties, propagated by Monte Carlo ([JCGM 101] §7, analysis/uncertainty/) through
// the figures' own computation, not through a linearised formula (docs/methods.md §16.4).
//
// Inputs (standard uncertainties, k = 1, normal; 0 = not stated):
//   u_reading_um         each reading on its own: drawn independently for every reading of the
//                        evaluated turn (one group input of the propagation, one budget entry);
//   u_bar_length_um      the calibrated bar length: one error δL shared by every reading;
//   u_bar_temperature_c  the bar's temperature: its growth α·L·δT (α = bar_expansion_ppm_per_k)
//                        shared by every reading.
// The machine's own scatter (the trace itself) is what the figures describe: it is not an input.
// Each draw adds f·(u_r·z_n + δL + α·L·δT) to the test's tool-path deviations (f = R_DBB / R,
// circular_test.h) and recomputes the figures exactly as the analysis does:
//   the least-squares circle (Gauss–Newton on the orthogonal distances, geometry/circle_fit.h):
//   two steps from the unperturbed fit with its design (geometry/circle_fit_radial.h: the
//   readings move along their fixed angles only), within 10⁻⁸ µm of the fit run to convergence,
//   and the full fit when a bound on what that leaves out exceeds 10⁻⁷ µm; circularity =
//   circular deviation G = the range of the residuals (ComputeIso230), the average radial error
//   R0 − R; the minimum zone (geometry/min_zone_radial.h) solved on the points near the
//   unperturbed zone's circles and then checked against every point (points outside the zone
//   are added and it is solved again), so it equals the minimum zone of all points;
//   for a pair, G(b) about the common circle (linearised as above) and H through the pair's
//   Iso230PairGeometry (iso230.h), built once: the angles do not change between draws.
// A pair shares the bar: one δL and one δT for both tests; its run also gives both tests'
// figures (one set of draws for the ten figures).
//
// The first-order GUM check ([JCGM 100] §5.1) beside it: the shared inputs by central
// differences of the same model; the reading group analytically from the linearised figure —
// R0 through the least-squares normal equations, a range of residuals through its two extreme
// readings and the least-squares hat matrix, the minimum zone through its contact readings
// (central differences of the zone on those; the others do not move it to first order). H, the
// largest difference of two interpolated traces, has no first-order term for the group here:
// its u_gum is NaN and a note says so.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "analysis/dbb/dbb_types.h"
#include "analysis/dbb/full_analysis.h"
#include "analysis/uncertainty/cross_check.h"
#include "analysis/uncertainty/monte_carlo.h"

namespace km::dbb {

// The ball bar's stated standard uncertainties for one test (0 = not stated).
struct DbbInputUncertainty {
  double reading_um = 0.0;
  double bar_length_um = 0.0;
  double bar_temperature_c = 0.0;
  double expansion_ppm_per_k = 0.0;  // α of the bar (with bar_temperature_c)
};

// Figure keys of a test's result, in the order of a test's outputs; then those of a pair.
inline constexpr std::array<const char*, 4> kDbbTestFigureKeys = {
    "circularity_um", "circular_deviation_um", "min_zone_circularity_um",
    "average_radial_error_um"};
inline constexpr std::array<const char*, 2> kDbbPairFigureKeys = {
    "circular_hysteresis_um", "bidirectional_circular_deviation_um"};
// Input names, in the order of the propagation's inputs.
inline constexpr std::array<const char*, 3> kDbbInputNames = {"u_reading_um", "u_bar_length_um",
                                                              "u_bar_temperature_c"};

struct DbbUncertaintyOptions {
  // M = 1000: the standard error of u is √((κ − 1)/(4M)) of u for an output of kurtosis κ,
  // 2.2 % for a normal one and 2.8 % for a range of extremes (κ ≈ 4): well under 10 % of U.
  std::size_t draws = 1000;
  std::uint64_t seed = 2304;
  std::size_t budget_draws = 200;  // per stated input (σ of a contribution to ~5 %)
  bool gum_check = true;
  // The 95 % interval needs M ≥ 1/(1 − p) = 20 draws ([JCGM 101] §7.2).
  void Check() const;  // throws km::InvalidInput naming the option out of its range
};

struct DbbUncertainty {
  uncertainty::McResult mc;  // outputs: the figure keys in order (see the functions)
  std::vector<std::string> figure_keys;
  std::vector<uncertainty::GumCheck> gum;  // u_gum NaN: no first-order value (notes)
  std::vector<std::string> notes;
};

// One test on its own: the four figures of kDbbTestFigureKeys.
DbbUncertainty PropagateDbbTest(const DbbTest& test, const DbbTestReport& report,
                                const DbbInputUncertainty& u,
                                const DbbUncertaintyOptions& options = {});

// A pair: outputs 0–3 the cw test's figures, 4–7 the ccw test's, 8–9 the pair's
// (kDbbPairFigureKeys). `u` of the shared inputs: the larger of the two files' (a note when they
// differ); each test's readings with its own u_reading_um.
DbbUncertainty PropagateDbbPair(const DbbTest& cw, const DbbTest& ccw, const DbbTestReport& rcw,
                                const DbbTestReport& rccw, const DbbPairReport& pair,
                                const DbbInputUncertainty& ucw, const DbbInputUncertainty& uccw,
                                const DbbUncertaintyOptions& options = {});

// The model PropagateDbbPair evaluates at every draw, for a draw given by its values: z, one
// standard normal per reading (cw then ccw, the evaluated turns' samples in time order), c the
// shared bar error in µm of bar; each reading moves by f·(u_r·z + c) (u_r its test's
// u_reading_um). Built once per pair: the angles, their orders and interpolation (H), the base
// fits and zones; a draw costs a few passes over the readings.
class DbbPairModel {
 public:
  DbbPairModel(const DbbTestReport& rcw, const DbbTestReport& rccw, double u_reading_cw,
               double u_reading_ccw);
  ~DbbPairModel();
  DbbPairModel(const DbbPairModel&) = delete;
  DbbPairModel& operator=(const DbbPairModel&) = delete;

  std::size_t cw_size() const;
  std::size_t ccw_size() const;
  // The ten figures in the order of PropagateDbbPair's outputs.
  void Evaluate(std::span<const double> z, double c, std::span<double> y);

 private:
  friend DbbUncertainty PropagateDbbPair(const DbbTest&, const DbbTest&, const DbbTestReport&,
                                         const DbbTestReport&, const DbbPairReport&,
                                         const DbbInputUncertainty&, const DbbInputUncertainty&,
                                         const DbbUncertaintyOptions&);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace km::dbb
