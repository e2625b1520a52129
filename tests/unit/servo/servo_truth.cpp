#include "tests/unit/servo/servo_truth.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <Eigen/Geometry>
#include <Eigen/LU>

namespace km::servo::truth {
namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Matrix3d Rot(const Eigen::Vector3d& deg) {
  const Eigen::Vector3d r = deg * kPi / 180.0;
  return (Eigen::AngleAxisd(r[0], Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(r[1], Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(r[2], Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

struct State {
  std::array<Eigen::Vector3d, 6> p, u, b;
  std::array<double, 6> len{};
  Eigen::Matrix<double, 6, 6> a;
};

State At(const Machine& m, const Eigen::Vector3d& tip, const Eigen::Matrix3d& r, double tool) {
  State s;
  for (int j = 0; j < 6; ++j) {
    s.p[j] = tip + r * (m.platform[j] + Eigen::Vector3d(0, 0, tool));
    const Eigen::Vector3d d = s.p[j] - m.base[j];
    s.len[j] = d.norm();
    s.u[j] = d / s.len[j];
    s.b[j] = s.p[j] - tip;
    s.a.block<3, 1>(0, j) = s.u[j];
    s.a.block<3, 1>(3, j) = s.b[j].cross(s.u[j]);
  }
  return s;
}

Eigen::Matrix<double, 6, 1> Hold(const State& s, const Eigen::Vector3d& f,
                                 const Eigen::Vector3d& mo) {
  Eigen::Matrix<double, 6, 1> rhs;
  rhs << f, mo;
  return s.a.fullPivLu().solve(rhs);
}

// Axial gravity forces (tension positive) and the strut tensions of the gravity load.
Eigen::Matrix<double, 6, 1> GravityAxial(const Machine& m, const State& s, const Eigen::Matrix3d& r,
                                         double tool, const Eigen::Vector3d& accel_m_s2,
                                         Eigen::Matrix<double, 6, 1>* with_inertia) {
  Eigen::Vector3d force = m.m_platform * m.g;
  const Eigen::Vector3d bp = r * (m.cog + Eigen::Vector3d(0, 0, tool));
  Eigen::Vector3d moment = bp.cross(force);
  for (int j = 0; j < 6; ++j) {
    const double l = s.len[j];
    const double w = (m.m_screw * (l - m.l2 - m.l3 / 2) + m.m_joint * l - m.m_motor * m.l1) / l;
    const Eigen::Vector3d wg = w * m.g;
    const Eigen::Vector3d carried = wg - wg.dot(s.u[j]) * s.u[j];
    force += carried;
    moment += s.b[j].cross(carried);
  }
  Eigen::Matrix<double, 6, 1> x = Hold(s, force, moment);
  for (int j = 0; j < 6; ++j) x[j] -= m.m_strut * m.g.dot(s.u[j]);
  if (with_inertia) {
    const Eigen::Vector3d fi = -m.m_platform * accel_m_s2;
    *with_inertia = x + Hold(s, fi, bp.cross(fi));
  }
  return x;
}

double Clamp1(double v) {
  return std::clamp(v, -1.0, 1.0);
}

// The part of a platform joint's motion d across its strut u: d(L u) less its axial part L̇ u,
// i.e. L du (eq. 3.11 read as a force normal to the strut, fig. 3.4).
Eigen::Vector3d Across(const Eigen::Vector3d& u, const Eigen::Vector3d& d) {
  return d - u.dot(d) * u;
}

// The friction direction of one base joint at a sample, from its direction `r` at the previous
// one. With no ramp it is the direction of the joint's swing velocity `v` (eq. 3.11 as printed).
// With a ramp λ the state in the plane normal to the strut moves by 2δ/λ with the swing δ and is
// held to |r| <= 1: integrated over `sub` steps of the analytic motion between the samples
// (`joint_at(k)`, `vel_at(k)`: the joint's position and velocity at sub-step k of `sub`).
template <typename JointAt, typename VelAt>
Eigen::Vector3d JointDirection(Eigen::Vector3d r, const Eigen::Vector3d& base, double ramp_mm,
                               int sub, JointAt joint_at, VelAt vel_at) {
  const auto unit_at = [&](int k) { return (joint_at(k) - base).normalized(); };
  if (ramp_mm <= 0.0) {
    const Eigen::Vector3d across = Across(unit_at(sub), vel_at(sub));
    const double n = across.norm();
    return n > 0.0 ? Eigen::Vector3d(across / n) : Across(unit_at(sub), r);
  }
  for (int k = 1; k <= sub; ++k) {
    const Eigen::Vector3d u = unit_at(k);
    r = Across(u, r) + (2.0 / ramp_mm) * Across(u, joint_at(k) - joint_at(k - 1));
    const double n = r.norm();
    if (n > 1.0) r /= n;
  }
  return r;
}

// The wrench of the base- and platform-joint friction of every strut (eqs. 3.11–3.12): strut j
// pushes its platform joint with −(f_t,j/L_j) r_j, f_t,j = t0 + t1·|ĝ_j| (the joint's bearings
// carry the size of the strut's axial gravity force, pulled or pushed; a negative sum no torque),
// and the platform joint's resistance adds its moment about r_j's rotation axis u_j × r_j.
void JointFrictionLoad(const Machine& m, const State& s, const Eigen::Matrix<double, 6, 1>& axial,
                       const std::array<Eigen::Vector3d, 6>& dir, Eigen::Vector3d& force,
                       Eigen::Vector3d& moment) {
  for (int j = 0; j < 6; ++j) {
    const double ft = std::max(0.0, m.t0 + m.t1 * std::abs(axial[j]));
    const double tau = m.leg_factor[j] * ft, rho = m.platform_factor[j] * ft;
    const Eigen::Vector3d f = -((tau + rho) / (s.len[j] / 1000.0)) * dir[j];
    force += f;
    moment += s.b[j].cross(f) + 1000.0 * rho * s.u[j].cross(dir[j]);
  }
}

}  // namespace

Machine Pm600Truth() {
  Machine m;
  m.base = {Eigen::Vector3d(128.905, 606.452, 0.0),   Eigen::Vector3d(-128.905, 606.452, 0.0),
            Eigen::Vector3d(-589.655, -191.591, 0.0), Eigen::Vector3d(-460.75, -414.861, 0.0),
            Eigen::Vector3d(460.75, -414.861, 0.0),   Eigen::Vector3d(589.655, -191.591, 0.0)};
  m.platform = {Eigen::Vector3d(133.826, 148.629, 250.0), Eigen::Vector3d(-133.826, 148.629, 250.0),
                Eigen::Vector3d(-195.63, 41.582, 250.0),  Eigen::Vector3d(-61.803, -190.211, 250.0),
                Eigen::Vector3d(61.803, -190.211, 250.0), Eigen::Vector3d(195.63, 41.582, 250.0)};
  return m;
}

std::vector<Circle> JigPlan(int samples) {
  struct Row {
    const char* id;
    int hole, level;
    double a, b, c;
  };
  const Row plan[] = {{"a", 9, 1, 20, 0, 0},  {"b", 4, 1, 0, 0, 0},   {"c", 6, 1, -20, 0, 0},
                      {"d", 8, 1, 0, 0, 0},   {"e", 2, 1, 0, 20, 0},  {"f", 9, 2, 0, 0, 0},
                      {"g", 3, 2, 15, 0, 0},  {"h", 5, 2, 0, 15, 0},  {"i", 7, 2, -15, 0, 0},
                      {"j", 1, 2, 0, -15, 0}, {"k", 9, 3, 10, 10, 0}, {"l", 4, 3, 0, 0, 0},
                      {"m", 6, 3, -10, 0, 0}, {"n", 8, 3, 0, -10, 0}, {"o", 2, 3, 0, -20, 0}};
  const double level_z[] = {0.0, -1150.0, -1050.0, -950.0};
  std::vector<Circle> out;
  for (const auto& row : plan) {
    Circle c;
    c.test_id = row.id;
    if (row.hole != 9) {
      const double phi = (row.hole - 1) * kPi / 4.0;
      c.centre = Eigen::Vector3d(100.0 * std::cos(phi), 100.0 * std::sin(phi), 0.0);
    } else {
      c.centre = Eigen::Vector3d::Zero();
    }
    c.centre.z() = level_z[row.level];
    const bool cone = row.level == 2;
    c.radius_mm = cone ? 144.0 : 150.0;
    c.z_offset_mm = cone ? 42.0 : 0.0;
    c.tilt_deg = Eigen::Vector3d(row.a, row.b, row.c);
    c.tool_mm = std::string(row.id) <= "h" ? 104.255 : 150.0;
    c.samples = samples;
    out.push_back(c);
  }
  return out;
}

std::vector<Circle> Strokes(int samples) {
  std::vector<Circle> out;
  const char* names[] = {"sx", "sy", "sz"};
  for (int k = 0; k < 3; ++k) {
    Circle c;
    c.test_id = names[k];
    c.radius_mm = k == 2 ? 100.0 : 150.0;
    c.axis_u = Eigen::Vector3d::Unit(k);
    c.axis_v = Eigen::Vector3d::Zero();
    c.samples = samples;
    out.push_back(c);
  }
  return out;
}

Record Simulate(const Machine& m, const Circle& c, double noise_N, std::mt19937& rng) {
  const int n = c.samples;
  const double sign = c.ccw ? 1.0 : -1.0;
  const double speed = c.feed_mm_min / 60.0;
  const Eigen::Matrix3d r = Rot(c.tilt_deg);
  std::vector<State> st;
  std::vector<Eigen::Vector3d> tip(n), acc(n);
  Record rec;
  for (int i = 0; i < n; ++i) {
    const double th = sign * 2.0 * kPi * (i + c.phase_steps) / n;
    const Eigen::Vector3d ring = std::cos(th) * c.axis_u + std::sin(th) * c.axis_v;
    tip[i] = c.centre + Eigen::Vector3d(0, 0, c.z_offset_mm) + c.radius_mm * ring;
    acc[i] = -(speed * speed / c.radius_mm) * ring * 1e-3;  // m/s²
    st.push_back(At(m, tip[i], r, c.tool_mm));
    rec.t_s.push_back(c.radius_mm * 2.0 * kPi * i / n / speed);
  }
  // Friction states, run through the closed path once before recording (steady state).
  std::array<double, 6> screw{};
  std::array<Eigen::Vector3d, 6> joint;
  joint.fill(Eigen::Vector3d::Zero());
  std::normal_distribution<double> noise(0.0, noise_N);
  for (int pass = 0; pass < 2; ++pass) {
    for (int i = 0; i < n; ++i) {
      const State& s = st[i];
      const State& prev = st[(i + n - 1) % n];
      // The platform turns not: every platform joint moves with the tool tip's velocity.
      const int sub = 16;
      const auto th_at = [&](int k) {
        return sign * 2.0 * kPi * (i - 1 + static_cast<double>(k) / sub + c.phase_steps) / n;
      };
      const auto tip_at = [&](int k) {
        const double th = th_at(k);
        return Eigen::Vector3d(c.centre + Eigen::Vector3d(0, 0, c.z_offset_mm) +
                               c.radius_mm * (std::cos(th) * c.axis_u + std::sin(th) * c.axis_v));
      };
      const auto vel_at = [&](int k) {
        const double th = th_at(k);
        return Eigen::Vector3d(sign * speed * (std::cos(th) * c.axis_v - std::sin(th) * c.axis_u));
      };
      for (int j = 0; j < 6; ++j) {
        screw[j] = Clamp1(screw[j] + 2.0 * (s.len[j] - prev.len[j]) / m.screw_ramp_mm);
        const Eigen::Vector3d arm = r * (m.platform[j] + Eigen::Vector3d(0, 0, c.tool_mm));
        joint[j] = JointDirection(
            joint[j], m.base[j], m.joint_ramp_mm, sub,
            [&](int k) { return Eigen::Vector3d(tip_at(k) + arm); }, vel_at);
      }
      if (pass == 0) continue;
      Eigen::Matrix<double, 6, 1> x;
      const auto axial = GravityAxial(m, s, r, c.tool_mm, acc[i], &x);
      Eigen::Vector3d force = c.external_N, moment = Eigen::Vector3d::Zero();
      JointFrictionLoad(m, s, axial, joint, force, moment);
      x += Hold(s, force, moment);
      std::array<double, 6> out{};
      for (int j = 0; j < 6; ++j) out[j] = x[j] - m.f0[j] * screw[j] + noise(rng);
      rec.force_N.push_back(out);
      rec.tip_mm.push_back(tip[i]);
    }
  }
  return rec;
}

std::string ServoText(const Circle& c, const Record& r, const std::string& machine_id) {
  std::string s = "# format: kinemetric-servo/1\n# machine_id: " + machine_id +
                  "\n# test_id: " + c.test_id +
                  "\n# motion: " + (c.IsCircle() ? "circle" : "path") +
                  "\n# direction: " + (c.ccw ? "ccw" : "cw") + "\n# force_unit: N\n";
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "# radius_mm: %.6f\n# centre_mm: %.6f, %.6f, %.6f\n# tilt_deg: %.6f, %.6f, "
                "%.6f\n# tool_length_mm: %.6f\n# feed_mm_min: %.3f\n",
                c.radius_mm, c.centre.x(), c.centre.y(), c.centre.z(), c.tilt_deg.x(),
                c.tilt_deg.y(), c.tilt_deg.z(), c.tool_mm, c.feed_mm_min);
  s += buf;
  s += "t_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,f1,f2,f3,f4,f5,f6\n";
  for (std::size_t i = 0; i < r.t_s.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f", r.t_s[i], r.tip_mm[i].x(),
                  r.tip_mm[i].y(), r.tip_mm[i].z(), c.tilt_deg.x(), c.tilt_deg.y(), c.tilt_deg.z());
    s += buf;
    for (double f : r.force_N[i]) {
      std::snprintf(buf, sizeof buf, ",%.4f", f);
      s += buf;
    }
    s += "\n";
  }
  return s;
}

}  // namespace km::servo::truth
