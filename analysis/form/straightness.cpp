#include "analysis/form/straightness.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "analysis/core/errors.h"
#include "analysis/geometry/line_fit.h"

namespace km::form {

void CheckProfile(const Profile& profile, std::size_t min_points) {
  const auto& x = profile.position_mm;
  const auto& e = profile.deviation_um;
  if (x.size() != e.size()) {
    throw InvalidInput("", 0, "deviation_um", "positions and deviations differ in number");
  }
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i])) throw InvalidInput("", 0, "position_mm", "value is not finite");
    if (!std::isfinite(e[i])) throw InvalidInput("", 0, "deviation_um", "value is not finite");
    if (i > 0 && !(x[i] > x[i - 1])) {
      throw InvalidInput("", 0, "position_mm", "positions must be strictly increasing");
    }
  }
  if (x.size() < min_points) {
    throw NotObservable("profile has " + std::to_string(x.size()) + " points; at least " +
                        std::to_string(min_points) + " are needed");
  }
}

StraightnessResult AnalyzeStraightness(const Profile& profile, const StraightnessOptions& options) {
  options.Check();
  CheckProfile(profile, 3);
  const auto& x = profile.position_mm;
  const auto& e = profile.deviation_um;
  StraightnessResult r;
  r.points = x.size();
  r.length_mm = x.back() - x.front();

  const geometry::Line2 lsq = geometry::FitLineLeastSquares(x, e);
  const geometry::Line2 ends = geometry::LineThroughEndPoints(x, e);
  const geometry::MinimumZoneLine zone = geometry::FitLineMinimumZone(x, e);
  r.straightness_lsq_um = geometry::PeakToValley(x, e, lsq);
  r.straightness_end_point_um = geometry::PeakToValley(x, e, ends);
  r.straightness_min_zone_um = zone.width;
  // um per mm -> um per m.
  r.slope_um_per_m = 1000.0 * lsq.slope;
  r.intercept_um = lsq.intercept;
  r.min_zone_slope_um_per_m = 1000.0 * zone.centre.slope;
  r.end_point_slope_um_per_m = 1000.0 * ends.slope;

  if (options.find_periodic) {
    std::vector<double> residual(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) residual[i] = e[i] - lsq(x[i]);
    r.periodic = FindPeriodicComponents(x, residual, options.periodic);
  }
  r.slope_with_periodic_um_per_m = r.slope_um_per_m;
  if (!r.periodic.empty()) {
    const double mx = 0.5 * (x.front() + x.back());
    const auto cols = static_cast<Eigen::Index>(2 + 2 * r.periodic.size());
    Eigen::MatrixXd a(static_cast<Eigen::Index>(x.size()), cols);
    Eigen::VectorXd b(static_cast<Eigen::Index>(x.size()));
    for (std::size_t i = 0; i < x.size(); ++i) {
      const auto row = static_cast<Eigen::Index>(i);
      a(row, 0) = 1.0;
      a(row, 1) = x[i] - mx;
      for (std::size_t k = 0; k < r.periodic.size(); ++k) {
        const double th = 2.0 * std::numbers::pi * x[i] / r.periodic[k].period_mm;
        a(row, static_cast<Eigen::Index>(2 + 2 * k)) = std::cos(th);
        a(row, static_cast<Eigen::Index>(3 + 2 * k)) = std::sin(th);
      }
      b(row) = e[i];
    }
    const Eigen::VectorXd c = a.colPivHouseholderQr().solve(b);
    r.slope_with_periodic_um_per_m = 1000.0 * c(1);
  }
  return r;
}

std::string ReversalSetupName(ReversalSetup setup) {
  return setup == ReversalSetup::kArtefactAndSensor ? "artefact_and_sensor" : "artefact";
}

ReversalSetup ParseReversalSetup(const std::string& name) {
  if (name == "artefact") return ReversalSetup::kArtefact;
  if (name == "artefact_and_sensor") return ReversalSetup::kArtefactAndSensor;
  throw InvalidInput("", 0, "reversal_setup",
                     "'" + name + "' is not one of artefact, artefact_and_sensor");
}

ReversalResult SeparateReversal(const Profile& a, const Profile& b, ReversalSetup setup) {
  CheckProfile(a, 3);
  CheckProfile(b, 3);
  // b = M - S (artefact turned over) or -M + S (artefact and sensor): the sign of M in b.
  const double machine_sign_in_b = setup == ReversalSetup::kArtefactAndSensor ? -1.0 : 1.0;
  const double lo = std::max(a.position_mm.front(), b.position_mm.front());
  const double hi = std::min(a.position_mm.back(), b.position_mm.back());
  // Positions of a closer than this to the ends of b count as inside (rounding in files).
  const double tol = 1e-9 * std::max(1.0, std::abs(hi) + std::abs(lo));
  ReversalResult out;
  out.setup = setup;
  if (setup == ReversalSetup::kArtefactAndSensor) {
    out.convention = "a = machine + artefact, b = -machine + artefact";
  }
  std::size_t j = 0;  // b segment [j, j + 1] containing the current position
  for (std::size_t i = 0; i < a.position_mm.size(); ++i) {
    const double x = a.position_mm[i];
    if (x < lo - tol || x > hi + tol) continue;
    while (j + 2 < b.position_mm.size() && b.position_mm[j + 1] < x) ++j;
    const double x0 = b.position_mm[j], x1 = b.position_mm[j + 1];
    const double t = std::clamp((x - x0) / (x1 - x0), 0.0, 1.0);
    const double bv = (1.0 - t) * b.deviation_um[j] + t * b.deviation_um[j + 1];
    const double av = a.deviation_um[i];
    out.positions_mm.push_back(x);
    out.machine_um.push_back(0.5 * (av + machine_sign_in_b * bv));
    out.artefact_um.push_back(0.5 * (av - machine_sign_in_b * bv));
  }
  if (out.positions_mm.size() < 3) {
    throw InvalidInput("", 0, "position_mm",
                       "the two reversal profiles share fewer than 3 positions");
  }
  const geometry::Line2 lm = geometry::FitLineLeastSquares(out.positions_mm, out.machine_um);
  const geometry::Line2 la = geometry::FitLineLeastSquares(out.positions_mm, out.artefact_um);
  out.machine_straightness_lsq_um = geometry::PeakToValley(out.positions_mm, out.machine_um, lm);
  out.artefact_straightness_lsq_um = geometry::PeakToValley(out.positions_mm, out.artefact_um, la);
  out.machine_slope_um_per_m = 1000.0 * lm.slope;
  out.artefact_slope_um_per_m = 1000.0 * la.slope;
  return out;
}

}  // namespace km::form
