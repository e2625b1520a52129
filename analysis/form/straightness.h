// Straightness of a measured profile e(x) (position x in mm, deviation e in um), and the
// reversal technique separating machine and artefact errors.
//
// Reference lines (analysis/geometry/line_fit.h):
//   straightness_lsq_um       = max - min of e_i - (c + m x_i), (m, c) the least-squares line
//   straightness_min_zone_um  = smallest vertical distance between two parallel lines enclosing
//                               all points (exact: convex hull + rotating calipers)
//   straightness_end_point_um = max - min of e_i about the line through the first and last point
//   slope_um_per_m            = 1000 m of the least-squares line (first-order component, e.g.
//                               squareness + artefact set-up, [Fujita thesis] ch. 8)
//   periodic[]                = significant periodic components of the least-squares residual
//                               (analysis/form/periodic.h; [Fujita thesis] fig. 4.10 and ch. 8)
//
// Reversal (straightedge / optical-flat reversal). Sign convention: in set-up a the sensor
// reads a(x) = M(x) + S(x), M the machine (carriage) straightness error, S the artefact form
// error. Set-up b is one of two reversals (header key reversal_setup of the file format):
//   artefact             the artefact is turned over about the travel axis (same positions) and
//                        the sensor stays, so the artefact error changes sign relative to the
//                        sensor: b(x) = M(x) - S(x), hence
//                          machine(x) = (a(x) + b(x)) / 2,  artefact(x) = (a(x) - b(x)) / 2;
//   artefact_and_sensor  the sensor is moved to the other side of the artefact as well, so it
//                        sees the artefact as before and the carriage from the other side:
//                        b(x) = -M(x) + S(x), hence
//                          machine(x) = (a(x) - b(x)) / 2,  artefact(x) = (a(x) + b(x)) / 2.
// b is interpolated linearly onto the positions of a inside the common range.
#pragma once

#include <string>
#include <vector>

#include "analysis/form/periodic.h"
#include "analysis/form/profile.h"

namespace km::form {

struct StraightnessOptions {
  bool find_periodic = true;
  PeriodicOptions periodic;
  void Check() const { periodic.Check(); }
};

struct StraightnessResult {
  std::size_t points = 0;
  double length_mm = 0.0;
  double straightness_lsq_um = 0.0;
  double straightness_min_zone_um = 0.0;
  double straightness_end_point_um = 0.0;
  double slope_um_per_m = 0.0;              // of the least-squares line
  double intercept_um = 0.0;                // least-squares line value at position 0
  double min_zone_slope_um_per_m = 0.0;     // of the minimum-zone lines
  double end_point_slope_um_per_m = 0.0;    // of the end-point line
  std::vector<PeriodicComponent> periodic;  // in the least-squares residual
  // Slope of the line fitted jointly with the periodic components (offset + slope + sum of
  // sinusoids at the found periods): free of the bias a partial or phase-shifted cycle puts
  // on the least-squares slope. Equals slope_um_per_m when no component is found.
  double slope_with_periodic_um_per_m = 0.0;
  // Which line slope_um_per_m, intercept_um and periodic[] refer to.
  std::string reference = "least_squares_line";
};

// Throws InvalidInput for mismatched sizes, NaN, or positions not strictly increasing, and
// NotObservable for fewer than 3 points.
StraightnessResult AnalyzeStraightness(const Profile& profile,
                                       const StraightnessOptions& options = {});

// How set-up b of a reversal pair was made (see above).
enum class ReversalSetup { kArtefact, kArtefactAndSensor };

// "artefact" | "artefact_and_sensor"; ParseReversalSetup throws InvalidInput (field
// reversal_setup) for any other name.
std::string ReversalSetupName(ReversalSetup setup);
ReversalSetup ParseReversalSetup(const std::string& name);

struct ReversalResult {
  std::vector<double> positions_mm;
  std::vector<double> machine_um;   // (a + b) / 2, or (a - b) / 2 with the sensor reversed too
  std::vector<double> artefact_um;  // (a - b) / 2, or (a + b) / 2 with the sensor reversed too
  double machine_straightness_lsq_um = 0.0;
  double artefact_straightness_lsq_um = 0.0;
  double machine_slope_um_per_m = 0.0;   // least-squares slope of machine_um
  double artefact_slope_um_per_m = 0.0;  // least-squares slope of artefact_um
  ReversalSetup setup = ReversalSetup::kArtefact;
  std::string convention = "a = machine + artefact, b = machine - artefact";
};

// Throws InvalidInput when a profile is malformed or the two overlap in fewer than 3 positions.
ReversalResult SeparateReversal(const Profile& a, const Profile& b,
                                ReversalSetup setup = ReversalSetup::kArtefact);

// Checks a profile: equal sizes, finite values, strictly increasing positions, >= min_points.
// Throws InvalidInput (field position_mm / deviation_um) or NotObservable.
void CheckProfile(const Profile& profile, std::size_t min_points);

}  // namespace km::form
