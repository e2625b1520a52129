// Independent simulator of hexapod servo loads for the recover-the-truth tests. It shares no
// code with analysis/servo or analysis/hexapod: its own rotation, joint positions, analytic
// velocities and accelerations of the circle, its own statics solve, the ball-screw friction
// ramping after every reversal of the strut (eq. 3.10 with a ramp), and the base-joint friction
// written from [PM-600 report] eqs. 3.11–3.12: the torque f_t,j = t0 + t1·ĝ_j of joint j acts as
// one force −(f_t,j/L_j)·unit(L_j dl_j/dt) at the platform joint, normal to the strut, against
// the joint's swing (by default at once, as eq. 3.11 prints it; optionally over a ramp).
// It writes `kinemetric-servo/1` text, so the parser is part of every test.
#pragma once

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace km::servo::truth {

struct Machine {
  std::array<Eigen::Vector3d, 6> base;      // Q_j
  std::array<Eigen::Vector3d, 6> platform;  // p_j, platform frame
  Eigen::Vector3d g{0.0, 0.0, -9.80665};    // m/s²
  double m_platform = 250.0;
  Eigen::Vector3d cog{0.0, 0.0, 180.0};  // platform frame, mm
  double m_screw = 12.0, m_joint = 6.0, m_motor = 18.0;
  double l1 = 100.0, l2 = 150.0, l3 = 1000.0;
  double m_strut = 27.0;
  std::array<double, 6> f0{151, 164, 219, 201, 182, 136};
  double t0 = 8.88, t1 = 0.0139;
  std::array<double, 6> leg_factor{1, 1, 1, 1, 1, 1};  // joint resistance multiplier per leg
  std::array<double, 6> platform_factor{};  // platform-joint resistance per leg, × the base's
  // The joint friction's direction after a reversal: 0 follows the swing at once (eq. 3.11);
  // λ > 0 passes to the other side over a swing of λ (a state on the unit disk).
  double joint_ramp_mm = 0.0;
  double screw_ramp_mm = 0.3;
};

Machine Pm600Truth();  // the values of data/machines/pm600-like.json

struct Circle {
  std::string test_id;
  bool ccw = true;
  Eigen::Vector3d centre{0, 0, -1150};
  double radius_mm = 150.0;
  double z_offset_mm = 0.0;
  Eigen::Vector3d tilt_deg = Eigen::Vector3d::Zero();
  double tool_mm = 104.255;
  double feed_mm_min = 1000.0;
  int samples = 720;
  double phase_steps = 0.0;  // the samples shifted along the circle by this fraction of a step
  Eigen::Vector3d external_N = Eigen::Vector3d::Zero();  // force on the tool tip
  // The tip moves on centre + radius·(cos θ u + sin θ v) at dθ/dt = feed/radius: the circle
  // with the defaults; v = 0 a straight stroke along u, sinusoidal in time, whose every
  // platform joint reverses its swing at both ends (a `path` record).
  Eigen::Vector3d axis_u = Eigen::Vector3d::UnitX(), axis_v = Eigen::Vector3d::UnitY();
  bool IsCircle() const {
    return std::abs(axis_u.norm() - 1.0) < 1e-12 && std::abs(axis_v.norm() - 1.0) < 1e-12 &&
           std::abs(axis_u.dot(axis_v)) < 1e-12;
  }
};

// Straight strokes of ±radius along x, y and z through the centre of the jig plan, level.
std::vector<Circle> Strokes(int samples = 720);

// The 15 fixed-ball positions of the jig plan ([PM-600 report] ch. 2), one circle each.
std::vector<Circle> JigPlan(int samples = 720);

// Motor forces (tension positive, N) of one circle with white noise of `noise_N`.
struct Record {
  std::vector<double> t_s;
  std::vector<Eigen::Vector3d> tip_mm;
  std::vector<std::array<double, 6>> force_N;
};
Record Simulate(const Machine& m, const Circle& c, double noise_N, std::mt19937& rng);

// `kinemetric-servo/1` text of a record.
std::string ServoText(const Circle& c, const Record& r,
                      const std::string& machine_id = "pm600-like");

}  // namespace km::servo::truth
