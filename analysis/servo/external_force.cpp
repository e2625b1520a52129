#include "analysis/servo/external_force.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/servo/hexapod_motion.h"
#include "analysis/servo/load_model.h"

namespace km::servo {
namespace {

double MedianAbs(std::vector<double> v) {
  if (v.empty()) return 0.0;
  for (double& x : v) x = std::abs(x);
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// σ of white noise from successive differences: MAD × 1.4826 / √2.
std::array<double, 6> NoiseFromDifferences(const std::vector<hexapod::Vector6d>& d) {
  std::array<double, 6> out{};
  for (int j = 0; j < 6; ++j) {
    std::vector<double> diff;
    diff.reserve(d.size());
    for (std::size_t i = 1; i < d.size(); ++i) diff.push_back(d[i][j] - d[i - 1][j]);
    out[j] = 1.4826 * MedianAbs(diff) / std::sqrt(2.0);
  }
  return out;
}

}  // namespace

void ForceOptions::Check() const {
  if (!(min_rate_fraction >= 0.0 && min_rate_fraction < 1.0)) {
    throw InvalidInput("", 0, "min_rate_fraction", "must be in [0, 1)");
  }
  if (!(reversal_skip_mm >= 0.0 && reversal_skip_mm < 1e3)) {
    throw InvalidInput("", 0, "reversal_skip_mm", "must be in [0, 1000) mm");
  }
  if (strut_noise_N) {
    for (double v : *strut_noise_N) {
      if (!(v >= 0.0 && v < 1e6)) throw InvalidInput("", 0, "strut_noise_N", "must be in [0, 1e6)");
    }
  }
}

ForceEstimate EstimateExternalForce(const hexapod::HexapodGeometry& geometry,
                                    const hexapod::MachinePhysics& physics, const ServoFile& file,
                                    const ForceOptions& options) {
  options.Check();
  if (!file.hexapod) {
    throw InvalidInput(file.file, 0, "axis", "a feed-drive file is not a hexapod servo record");
  }
  const auto motion = TrackMotion(geometry, file.samples, file.tool_length_mm);
  const auto moving = UsableRows(motion, options.min_rate_fraction, options.reversal_skip_mm);
  const LoadVector theta = ParametersOf(physics);
  const std::size_t n = motion.size();
  std::vector<hexapod::Vector6d> d(n);
  std::vector<std::array<bool, 6>> unknown_sign(n);
  std::vector<hexapod::Vector6d> ramp_var(n);
  std::array<double, 6> rate_min{};
  for (int j = 0; j < 6; ++j) {
    std::vector<double> rates(n);
    for (std::size_t i = 0; i < n; ++i) rates[i] = motion[i].strut_rate_mm_s[j];
    rate_min[j] = options.min_rate_fraction * MedianAbs(rates);
  }
  LoadRows a;
  hexapod::Vector6d c;
  for (std::size_t i = 0; i < n; ++i) {
    const hexapod::Vector6d g = StaticGravity(physics, theta, motion[i], file.tool_length_mm);
    std::array<double, 6> abs_g{};
    for (int j = 0; j < 6; ++j) abs_g[j] = std::abs(g[j]);
    // Joint friction with the direction of the latest swing of each joint (inside a ramp after
    // a reversal its size is uncertain: counted below); the screw friction only where the
    // strut's direction is known and settled (UsableRows).
    RowUse use = moving[i];
    use.joints = true;
    for (int j = 0; j < 6; ++j) {
      // The screw friction wherever the strut moves; its size is uncertain inside the ramp
      // after a reversal and at the start of the record (counted below).
      unknown_sign[i][j] = !use.screw[j];
      use.screw[j] = std::abs(motion[i].strut_rate_mm_s[j]) >= rate_min[j] && rate_min[j] > 0.0;
    }
    LoadRegressor(physics, motion[i], file.tool_length_mm, abs_g, use, a, c);
    const hexapod::Vector6d model = a * theta + c;
    for (int j = 0; j < 6; ++j) d[i][j] = file.samples[i].force_N[j] - model[j];
    ramp_var[i].setZero();
    if (!moving[i].joints) {
      const Eigen::PartialPivLU<hexapod::Matrix6d> lu(motion[i].frame.gamma);
      for (int k = 0; k < 6; ++k) {
        const double tau = theta[kT0] + theta[kT1] * abs_g[k];
        const hexapod::Vector6d x = tau * lu.solve(JointFrictionWrench(motion[i], k));
        ramp_var[i] += x.cwiseProduct(x) / 3.0;
      }
    }
  }
  ForceEstimate out;
  out.strut_noise_N = options.strut_noise_N ? *options.strut_noise_N : NoiseFromDifferences(d);
  out.t_s = file.t_s;
  out.force_N.resize(n);
  out.sigma_N.resize(n);
  Eigen::Matrix3d sum_cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Matrix<double, 3, 6> l;
    for (int j = 0; j < 6; ++j) l.col(j) = motion[i].frame.unit[j];
    out.force_N[i] = l * d[i];  // eq. 3.3
    hexapod::Vector6d var;
    for (int j = 0; j < 6; ++j) {
      const double f0 = unknown_sign[i][j] ? physics.screw_friction_N[j] : 0.0;
      var[j] = out.strut_noise_N[j] * out.strut_noise_N[j] + f0 * f0 / 3.0 + ramp_var[i][j];
    }
    const Eigen::Matrix3d cov = l * var.asDiagonal() * l.transpose();
    out.sigma_N[i] = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
    out.mean_force_N += out.force_N[i];
    sum_cov += cov;
  }
  if (n > 0) {
    out.mean_force_N /= static_cast<double>(n);
    out.mean_sigma_N = (sum_cov.diagonal() / static_cast<double>(n * n)).cwiseSqrt();
  }
  return out;
}

}  // namespace km::servo
