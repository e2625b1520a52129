// The external (cutting) force at the tool tip over time ([PM-600 report] eqs. 3.2–3.3, 3.13;
// docs/methods.md §12): per strut d̂_j = F_j − ĝ_j − f̂_j − F̂_j, the motor force less the
// modelled gravity, friction and inertia (pose second derivative by finite differences), and
// â = Σ d̂_j l_j.
//
// Friction follows the states of friction_states.h: each base joint's force −(f_t,j/L_j) r_j
// ([PM-600 report] eqs. 3.11–3.12) with its direction state r_j turning with the joint's swing,
// and the ball screws, go over to the other side after a reversal as a ramp over a travel λ. λ of
// the joints is the machine model's `joint_friction` ramp when given, λ of both otherwise the one
// that makes the estimated force smoothest (least sum of squared successive differences; a grid
// over log λ in [0.01, 20] mm and the step, then golden-section search) — a wrong λ leaves spikes
// at every reversal.
//
// Uncertainty per sample and axis: the strut forces' noise σ_j (from the record itself: the
// spread of successive differences of d̂_j, /√2, robust by the median absolute deviation, or
// given), and where a strut stands still the static friction, uniform in ±f0_j (σ = f0_j/√3).
#pragma once

#include <array>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "analysis/hexapod/statics.h"
#include "analysis/servo/servo_types.h"

namespace km::servo {

struct ForceOptions {
  double min_rate_fraction = 0.2;  // a strut below this × its median rate stands still
  std::optional<double> joint_ramp_mm, screw_ramp_mm;  // estimated from the record if unset
  std::optional<std::array<double, 6>> strut_noise_N;  // σ_j; estimated from the record if unset
  void Check() const;
};

struct ForceEstimate {
  std::vector<double> t_s;
  std::vector<Eigen::Vector3d> force_N;  // â, machine frame
  std::vector<Eigen::Vector3d> sigma_N;  // per axis
  // Per sample and strut the modelled motor force ĝ_j + f̂_j + F̂_j (gravity, friction with its
  // ramps, inertia): the motor force less d̂_j, what a record without an external load shows.
  std::vector<std::array<double, 6>> strut_model_N;
  std::array<double, 6> strut_noise_N{};
  double joint_ramp_mm = 0.0, screw_ramp_mm = 0.0;  // used (0: a step)
  bool joint_ramp_estimated = false, screw_ramp_estimated = false;
  Eigen::Vector3d mean_force_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_sigma_N = Eigen::Vector3d::Zero();  // of the mean
};

ForceEstimate EstimateExternalForce(const hexapod::HexapodGeometry& geometry,
                                    const hexapod::MachinePhysics& physics, const ServoFile& file,
                                    const ForceOptions& options = {});

}  // namespace km::servo
