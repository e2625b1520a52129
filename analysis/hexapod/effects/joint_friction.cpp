// joint_friction ([PM-600 report] eqs. 3.9–3.12, [Joint patent] figs. 10–12): each base joint
// resists the swing of its strut with a torque f_t,j = t0 + t1·ĝ_j (ĝ_j the strut's axial
// gravity force), a force of size f_t,j/L_j at the platform joint, normal to the strut and
// against its swing (analysis/hexapod/joint_swing.h, the one law of the product). After a
// reversal the direction passes to the other side over a joint travel λ (the patent's ramp;
// λ → 0 is eq. 3.11 as printed). The friction forces load the struts through the platform
// statics (eq. 3.9) and deflect them with the strut compliance of eq. 4.3.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Geometry>

#include "analysis/hexapod/effects/effect_list.h"
#include "analysis/hexapod/joint_swing.h"

namespace km::hexapod {
namespace {

using Joints = std::array<Eigen::Vector3d, 6>;

Joints PlatformJoints(const TestPath& path, std::size_t i) {
  Joints p;
  for (int j = 0; j < 6; ++j) p[j] = path.frame[i].lever_mm[j] + path.pose[i].tip_mm;
  return p;
}

// Friction direction states after each sample, from the commanded motion. A closed turn starts
// from the steady state of its own motion (run through once); an open path (a partial arc, a
// record with lead-in or lead-out) from steady sliding in the direction of each joint's first
// swing, so no reversal is invented at its first sample.
std::vector<Joints> SwingStates(const TestPath& path, double ramp_mm) {
  const std::size_t n = path.pose.size();
  std::vector<Joints> swing(n);
  Joints a = PlatformJoints(path, 0);
  for (std::size_t i = 1; i < n; ++i) {
    const Joints b = PlatformJoints(path, i);
    for (int j = 0; j < 6; ++j) swing[i][j] = SwingOf(path.frame[i].unit[j], b[j] - a[j]);
    a = b;
  }
  Joints r;
  for (int j = 0; j < 6; ++j) {
    r[j].setZero();
    for (std::size_t i = 1; i < n && r[j].isZero(); ++i)
      r[j] = StepSwingState(r[j], path.frame[i].unit[j], swing[i][j], 0.0);
  }
  if (path.closed_turn) {
    for (std::size_t i = 1; i < n; ++i)
      for (int j = 0; j < 6; ++j)
        r[j] = StepSwingState(r[j], path.frame[i].unit[j], swing[i][j], ramp_mm);
  }
  std::vector<Joints> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int j = 0; j < 6; ++j)
      if (i > 0) r[j] = StepSwingState(r[j], path.frame[i].unit[j], swing[i][j], ramp_mm);
    out[i] = r;
  }
  return out;
}

class JointFriction final : public HexapodEffect {
 public:
  const char* Name() const override { return "joint_friction"; }
  std::vector<EffectParameter> Parameters(const EffectSetup& s) const override {
    if (!s.physics || !s.physics->has_gravity) return {};  // needs ĝ and the compliance
    double t0 = 5.0, t1 = 0.0;
    if (s.physics->has_friction) {
      t0 = s.physics->base_joint_torque_Nm > 0.0 ? s.physics->base_joint_torque_Nm : t0;
      t1 = s.physics->base_joint_torque_per_N_m;
    }
    return {{"torque_Nm", "N*m", t0, 0.0, 1000.0, true, 1.0},
            {"ramp_mm", "mm", 0.05, 0.0, 50.0, true, 0.5},
            {"torque_per_N_m", "m", t1, -1.0, 1.0, true, 0.01}};
  }
  void Apply(const TestPath& path, const double* p, const ModelTerms& terms, const EffectSetup& s,
             Perturbation& out) const override {
    const std::size_t n = path.pose.size();
    if (n < 2 || !s.physics || path.gravity_N.empty()) return;
    const auto states = SwingStates(path, p[1]);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& f = path.frame[i];
      Eigen::Vector3d force = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
      for (int j = 0; j < 6; ++j) {
        const double tau = JointFrictionTorque(p[0], p[2], terms.GravityAt(path, i)[j]);
        const Eigen::Vector3d fj = -(tau / (1e-3 * f.length_mm[j])) * states[i][j];
        force += fj;
        moment += f.lever_mm[j].cross(fj);
      }
      const Vector6d x = TensionsForWrench(f, force, moment);
      const Vector6d k = StrutCompliance(*s.physics, f, terms.k_stiff2_mm_per_N);
      out.ds_mm[i] += k.cwiseProduct(x);
    }
  }
  const char* Signature() const override {
    return "opposite in CW and CCW (odd): the friction of each base joint opposes its strut's "
           "swing, so the tool lags its command along the path";
  }
  // Ramp lengths tried (0: eq. 3.11 as printed), each with t1 held at the machine file's value
  // and with t1 fitted too (the data identify t1 when the struts' loads vary enough between
  // the tests' poses).
  std::vector<Variant> Variants(const EffectSetup& s) const override {
    const auto params = Parameters(s);
    if (params.empty()) return {};
    std::vector<Variant> out;
    for (double ramp : {0.0, 0.7, 2.5}) {
      for (bool t1_free : {false, true}) {
        Variant v;
        v.params = params;
        v.params[1].value = ramp;
        v.params[2].free = t1_free;
        v.held = {1};
        char label[64];
        std::snprintf(label, sizeof label, "ramp_mm = %g%s", ramp, t1_free ? ", t1 fitted" : "");
        v.label = label;
        out.push_back(std::move(v));
      }
    }
    return out;
  }
};

}  // namespace

const HexapodEffect& JointFrictionEffect() {
  static const JointFriction e;
  return e;
}

}  // namespace km::hexapod
