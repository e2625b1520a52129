// Position-dependent errors of a trunnion table's rotary axes beside the eight location errors
// (docs/methods.md §17.6): the R-test model of rotary_model.h extended by the candidates of the
// missing-effect workflow (rotary_discover.h), and a joint least-squares fit of the location
// errors with any chosen set of them.
//
// Every parameter is a number in µm, µrad, µrad per rad or µm per hour, in this order:
//   0–7   the location errors (rotary_types.h)
//   8–12  angular positioning error of C: actual angle c + ε(c),
//         ε(c) = a1 cos c + b1 sin c + a2 cos 2c + b2 sin 2c + s·c   (µrad; s µrad per rad)
//   13–17 the same for the tilt axis, of t
//   18–25 radial error motion of C: the C line's point (at zero tilt, in its plane) moved by
//         (Σ_k xc_k cos kc + xs_k sin kc, Σ_k yc_k cos kc + ys_k sin kc), k = 2, 3   (µm)
//   26–29 thermal drift: XOC, YOC and the tilt line's two position errors change at a constant
//         rate from the first pose, µm per hour of time_s
// The sensors are zeroed at the first pose: a reading is the displacement at the pose minus the
// displacement at the first pose (zero for location errors alone, whose first pose is at zero
// angles).
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "analysis/rotary/rotary_types.h"

namespace km::rotary {

inline constexpr std::size_t kEffectParameterCount = 30;
using EffectParameters = std::array<double, kEffectParameterCount>;

enum class RotaryEffect { kCAngular, kTiltAngular, kCRadial, kDrift };
inline constexpr std::array<RotaryEffect, 4> kRotaryEffects{
    {RotaryEffect::kCAngular, RotaryEffect::kTiltAngular, RotaryEffect::kCRadial,
     RotaryEffect::kDrift}};

struct ParameterRange {
  std::size_t first = 0;
  std::size_t count = 0;
};

ParameterRange EffectRange(RotaryEffect e);
// "angular positioning error of C", "thermal drift of the axis lines", …
std::string EffectName(Kinematics k, RotaryEffect e);
// "c_angle_cos1_urad", "drift_XOC_um_per_h", the location errors "YOA_um", …
std::string ParameterKey(Kinematics k, std::size_t index);

// The poses as the fit uses them: angles in radians, hours from the first pose.
struct EffectPoses {
  RotarySetup setup;
  std::vector<double> tilt_rad, c_rad, hours;
  Eigen::VectorXd measured_um;  // x, y, z per pose
};

// Throws InvalidInput for fewer than 4 poses, non-finite values or a time column of another
// length (an empty time column: every pose at hour 0).
EffectPoses PrepareEffectPoses(const RotaryTest& test, const std::vector<double>& time_s);

// The model's readings (µm, x, y, z per pose) for all 30 parameters.
Eigen::VectorXd EffectReadings(const EffectPoses& p, const EffectParameters& x);

struct EffectFit {
  std::vector<std::size_t> free;  // the parameters fitted, ascending
  EffectParameters value{};       // the others 0
  EffectParameters sigma{};       // 0 where not fitted or not determined
  std::array<bool, kEffectParameterCount> determined{};
  std::size_t rank = 0;
  double rss = 0.0;     // µm²
  double s_um = 0.0;    // √(rss / (3N − rank))
  double rms_um = 0.0;  // √(rss / 3N): the gap
  Eigen::VectorXd residual_um;
};

// Gauss–Newton on the free parameters from zero, over the directions the poses determine
// (column-scaled SVD of the Jacobian at zero, relative tolerance 1e-8; a parameter with a squared
// share above 1e-6 in the rest is not determined), derivatives by central differences.
EffectFit FitEffects(const EffectPoses& p, const std::vector<std::size_t>& free);

}  // namespace km::rotary
