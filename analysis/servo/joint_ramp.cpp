#include "analysis/servo/joint_ramp.h"

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

using StateMap = Eigen::Matrix<double, 6, 18>;  // strut forces of the 6 × 3 joint states

// One record prepared for the search: per sample the residual without joint friction, and the
// strut forces of each joint's friction, linear in its direction state r_j (3 components), at
// the identified torque f_t,j = t0 + t1·ĝ_j.
struct Prepared {
  std::vector<hexapod::Vector6d> residual;
  std::vector<std::array<bool, 6>> row;
  std::vector<StateMap> state_forces;
  FrictionPath path;
};

// The strut forces of the joint friction per component of the states r_j (6 × 18).
StateMap StateForces(const LoadVector& theta, const MotionSample& s,
                     const std::array<double, 6>& gravity) {
  StateMap w;
  for (int j = 0; j < 6; ++j) {
    const double torque = hexapod::JointFrictionTorque(theta[kT0], theta[kT1], gravity[j]);
    w.middleCols<3>(3 * j) = torque * JointFrictionWrenchMap(s, j);
  }
  return Eigen::PartialPivLU<hexapod::Matrix6d>(s.frame.gamma).solve(w);
}

Prepared Prepare(const hexapod::HexapodGeometry& g, const hexapod::MachinePhysics& m,
                 const ServoFile& f, double min_rate_fraction, double skip) {
  const auto motion = TrackMotion(g, f.samples, f.tool_length_mm);
  const auto use = UsableRows(motion, min_rate_fraction, skip);
  const LoadVector theta = ParametersOf(m);
  const std::size_t n = motion.size();
  Prepared p;
  p.residual.resize(n);
  p.row.resize(n);
  p.state_forces.resize(n);
  LoadRows a;
  hexapod::Vector6d c;
  for (std::size_t i = 0; i < n; ++i) {
    const MotionSample& s = motion[i];
    const JointLoads loads =
        JointLoadsOf(StaticGravity(m, theta, s, f.tool_length_mm), theta[kT0], theta[kT1]);
    RowUse u = use[i];
    u.joints = false;  // joint friction modelled here
    LoadRegressor(m, s, f.tool_length_mm, loads, u, a, c);
    const hexapod::Vector6d model = a * theta + c;
    for (int j = 0; j < 6; ++j) {
      p.residual[i][j] = f.samples[i].force_N[j] - model[j];
      // Settled screw friction and a moving tool tip (the joints' own ramps are the subject).
      p.row[i][j] = use[i].screw[j] && s.tip_speed_mm_s > 0.0;
    }
    p.state_forces[i] = StateForces(theta, s, loads.gravity_N);
  }
  p.path = PathOf(motion);
  return p;
}

// Residual sum of squares with ramp λ (λ ≤ 0: the direction of the swing at once).
double Rss(const std::vector<Prepared>& recs, double lambda, std::size_t* rows) {
  double ss = 0.0;
  std::size_t count = 0;
  for (const auto& p : recs) {
    const auto states = JointFrictionStates(p.path, lambda);
    for (std::size_t i = 0; i < p.residual.size(); ++i) {
      Eigen::Matrix<double, 18, 1> r;
      for (int j = 0; j < 6; ++j) r.segment<3>(3 * j) = states[i][j];
      const hexapod::Vector6d e = p.residual[i] - p.state_forces[i] * r;
      for (int j = 0; j < 6; ++j) {
        if (!p.row[i][j]) continue;
        ss += e[j] * e[j];
        ++count;
      }
    }
  }
  if (rows) *rows = count;
  return ss;
}

}  // namespace

RampEstimate EstimateJointRamp(const hexapod::HexapodGeometry& geometry,
                               const hexapod::MachinePhysics& physics,
                               const std::vector<ServoFile>& files, double min_rate_fraction,
                               double reversal_skip_mm) {
  std::vector<Prepared> recs;
  for (const auto& f : files) {
    recs.push_back(Prepare(geometry, physics, f, min_rate_fraction, reversal_skip_mm));
  }
  RampEstimate out;
  const double step = Rss(recs, 0.0, &out.rows);
  if (out.rows == 0) throw NotObservable("servo loads: no moving sample for the joint ramp");
  // Grid over log λ, then golden-section search in the best bracket.
  const double lo = std::log(0.01), hi = std::log(20.0);
  const int grid = 24;
  int best = 0;
  double best_rss = INFINITY;
  for (int k = 0; k <= grid; ++k) {
    const double rss = Rss(recs, std::exp(lo + (hi - lo) * k / grid), nullptr);
    if (rss < best_rss) {
      best_rss = rss;
      best = k;
    }
  }
  double a = lo + (hi - lo) * std::max(best - 1, 0) / grid;
  double b = lo + (hi - lo) * std::min(best + 1, grid) / grid;
  const double gr = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 30; ++it) {
    const double m1 = b - gr * (b - a), m2 = a + gr * (b - a);
    if (Rss(recs, std::exp(m1), nullptr) < Rss(recs, std::exp(m2), nullptr)) {
      b = m2;
    } else {
      a = m1;
    }
  }
  const double x = 0.5 * (a + b);
  out.ramp_mm = std::exp(x);
  const double rss = Rss(recs, out.ramp_mm, nullptr);
  const double rows = static_cast<double>(out.rows);
  out.residual_rms_N = std::sqrt(rss / rows);
  out.step_residual_rms_N = std::sqrt(step / rows);
  // σ of λ from the curvature of the RSS in λ: var = 2 σ̂² / RSS''.
  const double h = 0.05 * out.ramp_mm;
  const double d2 = (Rss(recs, out.ramp_mm + h, nullptr) - 2.0 * rss +
                     Rss(recs, std::max(out.ramp_mm - h, 1e-6), nullptr)) /
                    (h * h);
  const double s2 = rss / std::max(rows - 1.0, 1.0);
  out.sigma_mm = d2 > 0.0 ? std::sqrt(2.0 * s2 / d2) : NAN;
  return out;
}

}  // namespace km::servo
