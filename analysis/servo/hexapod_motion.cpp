#include "analysis/servo/hexapod_motion.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "analysis/core/angles.h"
#include "analysis/hexapod/joint_swing.h"

namespace km::servo {
namespace {

// Neighbours and weights of the first derivative at i (central where possible).
struct Stencil {
  std::size_t a = 0, b = 0;
  double inv_dt = 0.0;
};

Stencil FirstDerivative(const std::vector<HexapodSample>& s, std::size_t i) {
  const std::size_t n = s.size();
  Stencil st;
  st.a = i == 0 ? 0 : i - 1;
  st.b = i + 1 < n ? i + 1 : n - 1;
  const double dt = s[st.b].t_s - s[st.a].t_s;
  st.inv_dt = dt > 0.0 ? 1.0 / dt : 0.0;
  return st;
}

Eigen::Vector3d SecondDerivative(const std::vector<HexapodSample>& s,
                                 const std::vector<MotionSample>& m, std::size_t i) {
  const std::size_t n = s.size();
  if (n < 3) return Eigen::Vector3d::Zero();
  const std::size_t c = std::clamp<std::size_t>(i, 1, n - 2);
  const double h1 = s[c].t_s - s[c - 1].t_s, h2 = s[c + 1].t_s - s[c].t_s;
  const Eigen::Vector3d& x0 = m[c - 1].pose.tip_mm;
  const Eigen::Vector3d& x1 = m[c].pose.tip_mm;
  const Eigen::Vector3d& x2 = m[c + 1].pose.tip_mm;
  return 2.0 * ((x2 - x1) / h2 - (x1 - x0) / h1) / (h1 + h2);
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

std::vector<MotionSample> TrackMotion(const hexapod::HexapodGeometry& g,
                                      const std::vector<HexapodSample>& samples,
                                      double tool_length_mm) {
  const std::size_t n = samples.size();
  std::vector<MotionSample> m(n);
  std::vector<Eigen::Matrix3d> rot(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& s = samples[i];
    m[i].pose.tip_mm = Eigen::Vector3d(s.tip_mm[0], s.tip_mm[1], s.tip_mm[2]);
    m[i].pose.abc_rad = Eigen::Vector3d(s.abc_deg[0], s.abc_deg[1], s.abc_deg[2]) * kDeg;
    m[i].frame = hexapod::StrutFrameAt(g, m[i].pose, tool_length_mm);
    rot[i] = hexapod::RotationABC(m[i].pose.abc_rad);
  }
  for (std::size_t i = 0; i < n; ++i) {
    const Stencil st = FirstDerivative(samples, i);
    MotionSample& cur = m[i];
    cur.dt_s = i > 0 ? samples[i].t_s - samples[i - 1].t_s
                     : (n > 1 ? samples[1].t_s - samples[0].t_s : 0.0);
    const auto& fa = m[st.a].frame;
    const auto& fb = m[st.b].frame;
    cur.tip_speed_mm_s = (m[st.b].pose.tip_mm - m[st.a].pose.tip_mm).norm() * st.inv_dt;
    cur.accel_mm_s2 = SecondDerivative(samples, m, i);
    const Eigen::Matrix3d rdot = (rot[st.b] - rot[st.a]) * st.inv_dt;
    const Eigen::Matrix3d w = rdot * rot[i].transpose();
    cur.platform_omega =
        0.5 * Eigen::Vector3d(w(2, 1) - w(1, 2), w(0, 2) - w(2, 0), w(1, 0) - w(0, 1));
    for (int j = 0; j < 6; ++j) {
      cur.strut_rate_mm_s[j] = (fb.length_mm[j] - fa.length_mm[j]) * st.inv_dt;
      const Eigen::Vector3d& l = cur.frame.unit[j];
      const Eigen::Vector3d ldot = (fb.unit[j] - fa.unit[j]) * st.inv_dt;
      cur.strut_omega[j] = l.cross(ldot);
      // The platform joint's velocity across the strut is L_j dl_j/dt; along l_j it moves
      // with the strut rate, which has no swing component.
      cur.swing_mm_s[j] = cur.frame.length_mm[j] * hexapod::SwingOf(l, ldot);
    }
  }
  return m;
}

namespace {

// Whether each sample of one signed rate is usable: moving at >= min_rate and at least
// `skip` of travel (|∫rate dt|) since the last reversal. Travel is integrated from the rates.
std::vector<bool> Settled(const std::vector<double>& rate, const std::vector<double>& dt,
                          double min_rate_fraction, double skip) {
  const std::size_t n = rate.size();
  std::vector<double> abs_rate(n);
  for (std::size_t i = 0; i < n; ++i) abs_rate[i] = std::abs(rate[i]);
  const double min_rate = min_rate_fraction * Median(abs_rate);
  std::vector<bool> ok(n, false);
  int last_sign = 0;
  double travel = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const int sign = rate[i] > 0.0 ? 1 : (rate[i] < 0.0 ? -1 : 0);
    if (sign != 0 && sign != last_sign) {
      last_sign = sign;
      travel = 0.0;
    }
    travel += abs_rate[i] * dt[i];
    ok[i] = last_sign != 0 && travel >= skip && abs_rate[i] >= min_rate && min_rate > 0.0;
  }
  return ok;
}

// Whether joint j's friction direction is known and settled at each sample: its swing speed is
// >= min_rate, and over the last `skip` of swing (∫|v| dt back from the sample) no sample's
// swing turned by more than 90° from the present one (v_k·v_i < 0: a reversal).
std::vector<bool> SwingSettled(const std::vector<MotionSample>& motion, int j,
                               double min_rate_fraction, double skip) {
  const std::size_t n = motion.size();
  std::vector<double> speed(n);
  for (std::size_t i = 0; i < n; ++i) speed[i] = motion[i].swing_mm_s[j].norm();
  const double min_rate = min_rate_fraction * Median(speed);
  std::vector<bool> ok(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    if (!(speed[i] >= min_rate && min_rate > 0.0)) continue;
    const Eigen::Vector3d& v = motion[i].swing_mm_s[j];
    double travel = 0.0;
    for (std::size_t k = i + 1; k-- > 0;) {
      if (motion[k].swing_mm_s[j].dot(v) < 0.0) break;
      travel += speed[k] * motion[k].dt_s;
      if (travel >= skip) {
        ok[i] = true;
        break;
      }
    }
  }
  return ok;
}

}  // namespace

std::vector<RowUse> UsableRows(const std::vector<MotionSample>& motion, double min_rate_fraction,
                               double reversal_skip_mm) {
  const std::size_t n = motion.size();
  std::vector<RowUse> use(n);
  if (n < 2) return use;
  std::vector<double> dt(n);
  std::vector<double> rate(n);
  auto settled_of = [&](auto rate_at) {
    for (std::size_t i = 0; i < n; ++i) rate[i] = rate_at(motion[i]);
    return Settled(rate, dt, min_rate_fraction, reversal_skip_mm);
  };
  for (std::size_t i = 0; i < n; ++i) dt[i] = motion[i].dt_s;
  const auto tip = settled_of([](const MotionSample& s) { return s.tip_speed_mm_s; });
  for (std::size_t i = 0; i < n; ++i) use[i].joints = tip[i];
  for (int j = 0; j < 6; ++j) {
    const auto screw = settled_of([j](const MotionSample& s) { return s.strut_rate_mm_s[j]; });
    for (std::size_t i = 0; i < n; ++i) use[i].screw[j] = screw[i];
    const auto swing = SwingSettled(motion, j, min_rate_fraction, reversal_skip_mm);
    for (std::size_t i = 0; i < n; ++i) use[i].joints = use[i].joints && swing[i];
  }
  return use;
}

}  // namespace km::servo
