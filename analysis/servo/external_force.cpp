#include "analysis/servo/external_force.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/hexapod/joint_swing.h"
#include "analysis/servo/friction_states.h"
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

// The record without its friction, and the strut forces of the joint friction per component
// of the joints' direction states (eqs. 3.11–3.12, linear in r_j).
struct Parts {
  std::vector<hexapod::Vector6d> d0;                // motor − gravity − inertia
  std::vector<Eigen::Matrix<double, 6, 18>> joint;  // per joint state component
  std::vector<Eigen::Matrix<double, 3, 6>> units;   // l_j
  FrictionPath path;
};

Parts Decompose(const hexapod::MachinePhysics& m, const std::vector<MotionSample>& motion,
                const ServoFile& file) {
  const LoadVector theta = ParametersOf(m);
  const std::size_t n = motion.size();
  Parts p;
  p.d0.resize(n);
  p.joint.resize(n);
  p.units.resize(n);
  LoadRows a;
  hexapod::Vector6d c;
  const RowUse none;  // no friction columns
  for (std::size_t i = 0; i < n; ++i) {
    const MotionSample& s = motion[i];
    const JointLoads loads =
        JointLoadsOf(StaticGravity(m, theta, s, file.tool_length_mm), theta[kT0], theta[kT1]);
    LoadRegressor(m, s, file.tool_length_mm, loads, none, a, c);
    const hexapod::Vector6d model = a * theta + c;
    Eigen::Matrix<double, 6, 18> w;
    for (int j = 0; j < 6; ++j) {
      p.d0[i][j] = file.samples[i].force_N[j] - model[j];
      p.units[i].col(j) = s.frame.unit[j];
      const double torque =
          hexapod::JointFrictionTorque(theta[kT0], theta[kT1], loads.gravity_N[j]);
      w.middleCols<3>(3 * j) = torque * JointFrictionWrenchMap(s, j);
    }
    p.joint[i] = Eigen::PartialPivLU<hexapod::Matrix6d>(s.frame.gamma).solve(w);
  }
  p.path = PathOf(motion);
  return p;
}

// d̂ with the friction states of the ramps.
std::vector<hexapod::Vector6d> Residual(const Parts& p, const hexapod::MachinePhysics& m,
                                        double joint_ramp, double screw_ramp) {
  std::vector<JointStates> r;
  std::vector<std::array<double, 6>> s;
  FrictionStates(p.path, joint_ramp, screw_ramp, r, s);
  std::vector<hexapod::Vector6d> d(p.d0.size());
  for (std::size_t i = 0; i < d.size(); ++i) {
    Eigen::Matrix<double, 18, 1> state;
    for (int j = 0; j < 6; ++j) state.segment<3>(3 * j) = r[i][j];
    d[i] = p.d0[i] - p.joint[i] * state;
    // The screw friction's share of the motor force is −f0_j s_j (eq. 3.10).
    for (int j = 0; j < 6; ++j) d[i][j] += m.screw_friction_N[j] * s[i][j];
  }
  return d;
}

double Roughness(const Parts& p, const hexapod::MachinePhysics& m, double joint_ramp,
                 double screw_ramp) {
  const auto d = Residual(p, m, joint_ramp, screw_ramp);
  double ss = 0.0;
  for (std::size_t i = 1; i < d.size(); ++i) {
    ss += (p.units[i] * d[i] - p.units[i - 1] * d[i - 1]).squaredNorm();
  }
  return ss;
}

// λ minimising `cost` over the step (0) and log λ in [0.01, 20] mm.
template <typename Cost>
double LineSearch(Cost cost) {
  const double lo = std::log(0.01), hi = std::log(20.0);
  const int grid = 24;
  double best_x = 0.0, best = cost(0.0);
  int best_k = -1;
  for (int k = 0; k <= grid; ++k) {
    const double c = cost(std::exp(lo + (hi - lo) * k / grid));
    if (c < best) {
      best = c;
      best_k = k;
    }
  }
  if (best_k < 0) return 0.0;
  double a = lo + (hi - lo) * std::max(best_k - 1, 0) / grid;
  double b = lo + (hi - lo) * std::min(best_k + 1, grid) / grid;
  const double gr = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 25; ++it) {
    const double m1 = b - gr * (b - a), m2 = a + gr * (b - a);
    if (cost(std::exp(m1)) < cost(std::exp(m2))) {
      b = m2;
    } else {
      a = m1;
    }
  }
  best_x = std::exp(0.5 * (a + b));
  return best_x;
}

}  // namespace

void ForceOptions::Check() const {
  if (!(min_rate_fraction >= 0.0 && min_rate_fraction < 1.0)) {
    throw InvalidInput("", 0, "min_rate_fraction", "must be in [0, 1)");
  }
  for (const auto* v : {&joint_ramp_mm, &screw_ramp_mm}) {
    if (*v && !(**v >= 0.0 && **v <= 100.0)) {
      throw InvalidInput("", 0, v == &joint_ramp_mm ? "joint_ramp_mm" : "screw_ramp_mm",
                         "must be in [0, 100] mm");
    }
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
  const Parts parts = Decompose(physics, motion, file);
  ForceEstimate out;
  out.joint_ramp_estimated = !options.joint_ramp_mm;
  out.screw_ramp_estimated = !options.screw_ramp_mm;
  out.joint_ramp_mm = options.joint_ramp_mm.value_or(0.0);
  out.screw_ramp_mm = options.screw_ramp_mm.value_or(0.0);
  for (int round = 0; round < 2; ++round) {
    if (out.joint_ramp_estimated) {
      out.joint_ramp_mm =
          LineSearch([&](double l) { return Roughness(parts, physics, l, out.screw_ramp_mm); });
    }
    if (out.screw_ramp_estimated) {
      out.screw_ramp_mm =
          LineSearch([&](double l) { return Roughness(parts, physics, out.joint_ramp_mm, l); });
    }
  }
  const auto d = Residual(parts, physics, out.joint_ramp_mm, out.screw_ramp_mm);
  const std::size_t n = d.size();
  std::array<double, 6> rate_min{};
  for (int j = 0; j < 6; ++j) {
    std::vector<double> rates(n);
    for (std::size_t i = 0; i < n; ++i) rates[i] = motion[i].strut_rate_mm_s[j];
    rate_min[j] = options.min_rate_fraction * MedianAbs(rates);
  }
  out.strut_noise_N = options.strut_noise_N ? *options.strut_noise_N : NoiseFromDifferences(d);
  out.t_s = file.t_s;
  out.force_N.resize(n);
  out.sigma_N.resize(n);
  out.strut_model_N.resize(n);
  Eigen::Matrix3d sum_cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const auto& l = parts.units[i];
    out.force_N[i] = l * d[i];  // eq. 3.3
    for (int j = 0; j < 6; ++j) out.strut_model_N[i][j] = file.samples[i].force_N[j] - d[i][j];
    hexapod::Vector6d var;
    for (int j = 0; j < 6; ++j) {
      // A strut at rest holds a static friction anywhere within ±f0_j.
      const bool still =
          !(std::abs(motion[i].strut_rate_mm_s[j]) >= rate_min[j] && rate_min[j] > 0.0);
      const double f0 = still ? physics.screw_friction_N[j] : 0.0;
      var[j] = out.strut_noise_N[j] * out.strut_noise_N[j] + f0 * f0 / 3.0;
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
