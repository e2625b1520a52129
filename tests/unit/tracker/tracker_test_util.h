// Shared set-ups for the tracker tests: [Tracker paper]'s machine (target on the spindle of a
// 3-axis machine, 4 trackers on the table 0.6–1.2 m away) with a few µm of geometric error.
#pragma once

#include <cmath>
#include <set>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/SVD>

#include "analysis/tracker/tracker_selfcal.h"
#include "analysis/tracker/tracker_sim.h"

namespace km::tracker::test {

inline MachineErrorModel FewMicronMachine(const Eigen::Vector3d& centre, double size_mm) {
  MachineErrorModel m;
  m.centre_mm = centre;
  m.half_range_mm = Eigen::Vector3d::Constant(size_mm / 2);
  m.scale_ppm = {20, -10, 15};
  m.squareness_um_per_m = {20, -15, 10};
  m.poly_um[0][1][2] = 1.5;   // x straightness in y, quadratic
  m.poly_um[1][1][3] = -0.8;  // y positioning, cubic
  m.poly_um[2][0][2] = 1.0;   // z straightness in x
  return m;
}

inline TrackerSimOptions MakeSetup(double size_mm, int per_axis, int trackers, unsigned seed) {
  const Eigen::Vector3d centre(300, 200, 250);
  TrackerSimOptions o;
  o.seed = seed;
  o.commanded_mm = GridPoints(centre, size_mm, per_axis);
  o.trackers_mm = PlaceTrackers(centre, trackers, 600, 1200, seed);
  o.machine = FewMicronMachine(centre, size_mm);
  o.noise_um = 0.2;
  return o;
}

// Two gross errors on point `row` of a 4-tracker survey that cancel in its single redundant
// reading: +size_um on one tracker and the amount on another that leaves the redundant
// combination aᵀd (a ⟂ the four lines of sight) unchanged. The readings then fit a point
// displaced by tens of µm; no residual can show it. Returns the displacement (µm).
inline Eigen::Vector3d AddCancellingGrossErrors(TrackerSimResult& sim,
                                                const std::vector<Eigen::Vector3d>& trackers_mm,
                                                int row, double size_um) {
  const auto i = static_cast<std::size_t>(row);
  Eigen::Matrix<double, 4, 3> D;
  for (int j = 0; j < 4; ++j) {
    D.row(j) =
        (sim.true_points_mm[i] - trackers_mm[static_cast<std::size_t>(j)]).normalized().transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix<double, 4, 3>> svd(D, Eigen::ComputeFullU);
  const Eigen::Vector4d a = svd.matrixU().col(3);
  int k = 1;
  for (int j = 2; j < 4; ++j) {
    if (std::abs(a(j)) > std::abs(a(k))) k = j;
  }
  Eigen::Vector4d delta = Eigen::Vector4d::Zero();
  delta(0) = size_um;
  delta(k) = -size_um * a(0) / a(k);
  for (int j = 0; j < 4; ++j) sim.readings.displacement_um(row, j) += delta(j);
  return (D.transpose() * D).ldlt().solve(D.transpose() * delta);
}

struct Accuracy {
  double volumetric_rms_um = 0;   // RMS over all components (dx, dy, dz) of estimate − truth
  double predicted_rms_um = 0;    // the same from position_uncertainty_um
  double tracker_max_um = 0;      // largest |estimate − truth| of a tracker (gauge frame)
  double tracker_max_sigmas = 0;  // largest component error in predicted σ
  int valid_points = 0;
};

inline Accuracy Evaluate(const TrackerSimOptions& o, const TrackerSimResult& sim,
                         const SelfCalResult& r) {
  Accuracy a;
  const RigidTransform gauge = GaugeTransform(o.trackers_mm);
  for (std::size_t j = 0; j < o.trackers_mm.size(); ++j) {
    const Eigen::Vector3d err = 1e3 * (r.trackers_mm[j] - gauge.Apply(o.trackers_mm[j]));
    a.tracker_max_um = std::max(a.tracker_max_um, err.norm());
    for (int k = 0; k < 3; ++k) {
      const double s = r.tracker_uncertainty_um[j](k);
      if (s > 0) a.tracker_max_sigmas = std::max(a.tracker_max_sigmas, std::abs(err(k)) / s);
    }
  }
  // Truth: the true points after their own best fit to the commanded frame.
  std::vector<char> use = r.point_valid;
  const RigidTransform truth = FitRigid(sim.true_points_mm, o.commanded_mm, &use);
  double s = 0, sp = 0;
  for (std::size_t i = 0; i < o.commanded_mm.size(); ++i) {
    if (!use[i]) continue;
    const Eigen::Vector3d et = 1e3 * (truth.Apply(sim.true_points_mm[i]) - o.commanded_mm[i]);
    s += (r.volumetric_error_um[i] - et).squaredNorm();
    sp += r.position_uncertainty_um[i].squaredNorm();
    ++a.valid_points;
  }
  a.volumetric_rms_um = std::sqrt(s / (3.0 * a.valid_points));
  a.predicted_rms_um = std::sqrt(sp / (3.0 * a.valid_points));
  return a;
}

}  // namespace km::tracker::test
