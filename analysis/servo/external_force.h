// The external (cutting) force at the tool tip over time ([PM-600 report] eqs. 3.2–3.3, 3.13;
// docs/methods.md §12): per strut d̂_j = F_j − ĝ_j − f̂_j − F̂_j, the motor force less the
// modelled gravity, friction and inertia (pose second derivative by finite differences), and
// â = Σ d̂_j l_j.
//
// Uncertainty per sample and axis: the strut forces' noise σ_j (from the record itself: the
// spread of successive differences of d̂_j, /√2, robust by the median absolute deviation, or
// given), and, where a strut stands still or has just reversed, the friction the model cannot
// know the sign of: the ball-screw friction is then left out and counted as uniform in
// ±f0_j (σ = f0_j/√3).
#pragma once

#include <array>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "analysis/hexapod/statics.h"
#include "analysis/servo/servo_types.h"

namespace km::servo {

struct ForceOptions {
  double min_rate_fraction = 0.2;  // as IdentifyOptions
  double reversal_skip_mm = 1.0;
  std::optional<std::array<double, 6>> strut_noise_N;  // σ_j; estimated from the record if unset
  void Check() const;
};

struct ForceEstimate {
  std::vector<double> t_s;
  std::vector<Eigen::Vector3d> force_N;  // â, machine frame
  std::vector<Eigen::Vector3d> sigma_N;  // per axis
  std::array<double, 6> strut_noise_N{};
  Eigen::Vector3d mean_force_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_sigma_N = Eigen::Vector3d::Zero();  // of the mean
};

ForceEstimate EstimateExternalForce(const hexapod::HexapodGeometry& geometry,
                                    const hexapod::MachinePhysics& physics, const ServoFile& file,
                                    const ForceOptions& options = {});

}  // namespace km::servo
