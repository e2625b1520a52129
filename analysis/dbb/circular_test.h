// Circular-test (DBB) figures of [PM-600 report] §4.2.4 (eqs. 4.6–4.8):
//
//   planar representation  X_n = (R + ΔR_n) cos θ_n,  Y_n = (R + ΔR_n) sin θ_n
//   least-squares circle    (X0, Y0, R0) = argmin Σ (|(X_n, Y_n) − (X0, Y0)| − R0)²     (4.6)
//   radial error about it   ΔR'_n = (R / R_DBB) (|(X_n, Y_n) − (X0, Y0)| − R_DBB)      (4.7)
//   circularity             Δ = (R_DBB / R) (max ΔR'_n − min ΔR'_n)                    (4.8)
//
// R is the commanded radius of the moving-ball circle, R_DBB the bar length, ΔR_n the bar
// deviation (bar length − R_DBB). Δ is therefore the range of the bar deviation about the
// least-squares centre, in bar-length units. The centre offset is (X0, Y0) relative to the
// commanded centre, in the plane's (first axis, second axis); the average radial error is
// R0 − R (for a flat test R = R_DBB and this is the seed's R0 − R_DBB; for a cone test the
// seed's literal R0 − R_DBB would contain the constant R − R_DBB, which is not an error).
//
// Modes:
//  * centre_corrected (no fixed_ball_mm): the fitted centre absorbs set-up errors (fixed-ball
//    placement, moving-ball run-out); the centre offset is reported but is not a machine error.
//  * absolute (fixed_ball_mm given, [PM-600 report] §2.3 "jig"): the nominal bar length for a
//  perfect
//    machine, |P_cmd(θ) − F|, is computed in 3-D from the commanded circle (centre, radius,
//    z offset, plane) and the measured fixed ball F, and subtracted. What remains is the
//    machine's own error, so the fitted centre is the machine's positioning error of the circle
//    centre, and the range of the deviations without any centre fit is reported as
//    `radial_error_range_um` (radial error range about the fixed ball).
//
// Exactly one turn is evaluated: when the rows cover more than 360° (lead-in / lead-out arcs),
// the 360° window centred in the covered span is used and reported. Partial arcs (coverage.h:
// declared arc_deg < 360, or samples that do not come back to their start) are evaluated over
// the arc: the least-squares circle, the circularity and every figure derived from this result
// are then figures OVER THE ARC (full_turn = false, arc_deg = its length), which is stated in
// every result. Which samples are enough is one rule for all tests: the largest gap, the
// closing gap included, is at most 10° (coverage.h).
//
// Units of the deviations (cone tests). The bar reads the change of the distance between its
// balls; ISO 230-4 defines the figures (G, F, H, G(b)) as deviations of the tool path, radial
// in the plane of the circle. With the fixed ball at the apex of a cone (the moving-ball plane
// z_offset from it, bar length L = R_DBB, in-plane radius R = √(L² − z²)), an in-plane radial
// deviation Δr of the tool changes the bar length by ∂L/∂r · Δr = (R / L)·Δr, and a shift δ of
// the circle centre in the plane by (R / L)·δ·cos(θ − φ), to first order (the next term is
// z²·Δl² / (2 R³), 3·10⁻⁵ µm for Δl = 10 µm on the 150 / 144 / 42 mm cone). So
// Δr = Δl · L / R: DeviationUnits::kToolPath multiplies every bar deviation by
// ToolPathFactor(test) = L / R before the planar representation, and every figure of the
// result (centre offset, average radial error, circularity, the trace, the absolute-mode
// ranges) is then in tool-path units; kBar keeps the bar's own units (what the diagnosis,
// diagnosis.h MakeDiagnosisTrace, takes: it applies the same factor itself). For a flat test
// L = R and the factor is 1: both units agree exactly.
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "analysis/dbb/dbb_types.h"

namespace km::dbb {

enum class Mode { kCentreCorrected, kAbsolute };
const char* ToString(Mode m);

enum class DeviationUnits { kBar, kToolPath };
const char* ToString(DeviationUnits u);  // "bar" or "tool path (in-plane)"

// Bar deviation → in-plane radial deviation of the tool path: R_DBB / R (1 for a flat test).
double ToolPathFactor(const DbbTest& test);

// Samples of one evaluated turn (or partial arc), in time order.
struct Turn {
  std::vector<double> angle_rad;  // commanded angle, unwrapped as in the file
  std::vector<double> dr_um;      // bar deviation (absolute mode: minus the nominal set-up term)
  std::size_t first_index = 0;    // index of the first used row in the test's samples
  double start_deg = 0.0;         // window [start, end) in the file's angle units
  double end_deg = 0.0;           // (a partial arc: [start, end], both ends included)
  bool full_turn = true;
  double arc_deg = 360.0;  // evaluated arc length
};

// Selects exactly one turn, or the partial arc (see above). Throws km::InvalidInput when the
// samples break the coverage rule (coverage.h) or are not monotonic in the test's direction.
Turn SelectOneTurn(const DbbTest& test);

struct CircularTestResult {
  std::string test_id;
  Direction direction = Direction::kCcw;
  Mode mode = Mode::kCentreCorrected;
  DeviationUnits units = DeviationUnits::kBar;  // of every deviation below (see above)
  double deviation_factor = 1.0;             // applied to the bar deviations: 1 (kBar) or R_DBB / R
  std::array<double, 2> centre_offset_um{};  // (X0, Y0) eq. 4.6, plane axes
  double average_radial_error_um = 0.0;      // R0 − R
  double circularity_um = 0.0;               // eq. 4.8
  double fitted_radius_mm = 0.0;             // R0
  double fit_rms_um = 0.0;                   // rms of the residuals about the fitted circle
  std::size_t sample_count = 0;              // samples in the evaluated turn
  double turn_start_deg = 0.0;
  double turn_end_deg = 0.0;
  bool full_turn = true;   // false: a partial arc, every figure is over the arc
  double arc_deg = 360.0;  // length of the evaluated arc
  // Absolute mode only:
  std::optional<double> radial_error_range_um;  // max − min deviation about the fixed ball
  std::optional<double> mean_radial_error_about_fixed_ball_um;
  std::optional<std::array<double, 2>> machine_centre_error_um;  // in-plane (tool path)
  // Per-sample trace of the evaluated turn: angle and deviation about the fitted circle
  // (|(X_n, Y_n) − (X0, Y0)| − R0), µm.
  std::vector<double> angle_deg;
  std::vector<double> radial_error_um;
  // cos θ and sin θ of every sample (filled by AnalyzeCircularTest, so that the later stages
  // need no trigonometry of their own; read through CosAngle / SinAngle).
  std::vector<double> cos_angle;
  std::vector<double> sin_angle;
};

// cos θ_i, sin θ_i of sample i of a result: the cached values when present, computed otherwise
// (inline: the later stages read them sample by sample).
inline double CosAngle(const CircularTestResult& r, std::size_t i) {
  return r.cos_angle.size() == r.angle_deg.size()
             ? r.cos_angle[i]
             : std::cos(r.angle_deg[i] * std::numbers::pi / 180.0);
}
inline double SinAngle(const CircularTestResult& r, std::size_t i) {
  return r.sin_angle.size() == r.angle_deg.size()
             ? r.sin_angle[i]
             : std::sin(r.angle_deg[i] * std::numbers::pi / 180.0);
}

// Full figures of one test, in bar units (the default) or tool-path units. Throws
// km::InvalidInput on unusable data.
CircularTestResult AnalyzeCircularTest(const DbbTest& test,
                                       DeviationUnits units = DeviationUnits::kBar);

// Commanded position of the moving ball at angle θ (mm, machine frame), and the plane's unit
// axes (first, second, normal) — shared with the simulation so both agree on geometry.
std::array<std::array<double, 3>, 3> PlaneAxes(Plane plane);
std::array<double, 3> CommandedBallPosition(const DbbTest& test, double angle_rad);

}  // namespace km::dbb
