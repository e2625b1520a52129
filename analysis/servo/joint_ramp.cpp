#include "analysis/servo/joint_ramp.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/servo/hexapod_motion.h"
#include "analysis/servo/load_model.h"

namespace km::servo {
namespace {

// One record prepared for the search: per sample the residual without joint friction, and the
// strut forces of each joint axis's friction at full state (r = 1).
struct Prepared {
  std::vector<hexapod::Vector6d> residual;
  std::vector<std::array<bool, 6>> row;
  std::vector<Eigen::Matrix<double, 6, 12>> axis_forces;
  std::vector<std::array<std::array<double, 2>, 6>> swing_mm;  // δ since the previous sample
};

Prepared Prepare(const hexapod::HexapodGeometry& g, const hexapod::MachinePhysics& m,
                 const ServoFile& f, double min_rate_fraction, double skip) {
  const auto motion = TrackMotion(g, f.samples, f.tool_length_mm);
  const auto use = UsableRows(motion, min_rate_fraction, skip);
  const LoadVector theta = ParametersOf(m);
  const std::size_t n = motion.size();
  Prepared p;
  p.residual.resize(n);
  p.row.resize(n);
  p.axis_forces.resize(n);
  p.swing_mm.resize(n);
  LoadRows a;
  hexapod::Vector6d c;
  for (std::size_t i = 0; i < n; ++i) {
    const MotionSample& s = motion[i];
    const hexapod::Vector6d grav = StaticGravity(m, theta, s, f.tool_length_mm);
    RowUse u = use[i];
    u.joints = false;  // joint friction modelled here
    std::array<double, 6> abs_g{};
    for (int j = 0; j < 6; ++j) abs_g[j] = std::abs(grav[j]);
    LoadRegressor(m, s, f.tool_length_mm, abs_g, u, a, c);
    const hexapod::Vector6d model = a * theta + c;
    const std::size_t prev = i == 0 ? n - 1 : i - 1;
    Eigen::Matrix<double, 6, 12> w;
    for (int j = 0; j < 6; ++j) {
      p.residual[i][j] = f.samples[i].force_N[j] - model[j];
      // Settled screw friction and a moving tool tip (the joints' own ramps are the subject).
      p.row[i][j] = use[i].screw[j] && s.tip_speed_mm_s > 0.0;
      const double tau = theta[kT0] + theta[kT1] * abs_g[j];
      const Eigen::Vector3d pj = s.frame.lever_mm[j] + s.pose.tip_mm;
      const Eigen::Vector3d pp = motion[prev].frame.lever_mm[j] + motion[prev].pose.tip_mm;
      for (int k = 0; k < 2; ++k) {
        const Eigen::Vector3d force = -(tau * 1e3 / s.frame.length_mm[j]) * s.swing_axis[j][k];
        w.block<3, 1>(0, 2 * j + k) = force;
        w.block<3, 1>(3, 2 * j + k) = s.frame.lever_mm[j].cross(force);
        p.swing_mm[i][j][k] = s.swing_axis[j][k].dot(pj - pp);
      }
    }
    p.axis_forces[i] = Eigen::PartialPivLU<hexapod::Matrix6d>(s.frame.gamma).solve(w);
  }
  return p;
}

// Residual sum of squares with ramp λ (λ ≤ 0: a step at the reversal).
double Rss(const std::vector<Prepared>& recs, double lambda, std::size_t* rows) {
  double ss = 0.0;
  std::size_t count = 0;
  for (const auto& p : recs) {
    const std::size_t n = p.residual.size();
    std::array<double, 12> r{};
    const auto advance = [&](std::size_t i) {
      for (int q = 0; q < 12; ++q) {
        const double d = p.swing_mm[i][q / 2][q % 2];
        r[q] = lambda > 0.0 ? std::clamp(r[q] + 2.0 * d / lambda, -1.0, 1.0)
                            : (d > 0.0 ? 1.0 : (d < 0.0 ? -1.0 : r[q]));
      }
    };
    for (std::size_t i = 0; i < n; ++i) advance(i);  // steady state of the record's motion
    for (std::size_t i = 0; i < n; ++i) {
      advance(i);
      const Eigen::Map<const Eigen::Matrix<double, 12, 1>> state(r.data());
      const hexapod::Vector6d e = p.residual[i] - p.axis_forces[i] * state;
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
