// joint_friction ([PM-600 report] eqs. 3.9–3.12, [Joint patent] figs. 10–12): each base joint
// resists the swing of its strut with τ_j = t0 + t1·|F_j| (F_j the gravity axial force), a force
// τ_j/L_j at the platform joint perpendicular to the strut and opposing the swing. After a
// reversal of the swing along one joint axis the force goes over to the other side as a linear
// ramp over a joint travel λ (the patent's ramp; a step fits badly). The friction forces load the
// struts through the platform statics and deflect them with the strut compliance.
#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "analysis/hexapod/effects/effect_list.h"

namespace km::hexapod {
namespace {

// Swing axes of a strut: a1 ⟂ (strut, vertical), a2 = l × a1.
std::array<Eigen::Vector3d, 2> SwingAxes(const Eigen::Vector3d& l) {
  Eigen::Vector3d a1 = Eigen::Vector3d::UnitZ().cross(l);
  if (a1.norm() < 1e-9) a1 = Eigen::Vector3d::UnitX().cross(l);
  a1.normalize();
  return {a1, l.cross(a1)};
}

class JointFriction final : public HexapodEffect {
 public:
  const char* Name() const override { return "joint_friction"; }
  std::vector<EffectParameter> Parameters(const EffectSetup& s) const override {
    if (!s.physics || !s.physics->has_gravity) return {};  // needs the strut compliance
    double t0 = 5.0, t1 = 0.0;
    if (s.physics && s.physics->has_friction) {
      t0 = s.physics->base_joint_torque_Nm > 0.0 ? s.physics->base_joint_torque_Nm : t0;
      t1 = s.physics->base_joint_torque_per_N_m;
    }
    return {{"torque_Nm", "N*m", t0, 0.0, 1000.0, true, 1.0},
            {"ramp_mm", "mm", 2.0, 0.01, 50.0, true, 0.5},
            {"torque_per_N_m", "m", t1, 0.0, 1.0, false, 0.01}};
  }
  void Apply(const TestPath& path, const double* p, const ModelTerms& terms, const EffectSetup& s,
             Perturbation& out) const override {
    const std::size_t n = path.pose.size();
    if (n < 2 || !s.physics) return;
    const double lambda = std::max(p[1], 1e-6);
    std::array<std::array<double, 2>, 6> r{};
    std::vector<std::array<Eigen::Vector3d, 6>> joints(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& f = path.frame[i];
      for (int j = 0; j < 6; ++j) joints[i][j] = f.lever_mm[j] + path.pose[i].tip_mm;
    }
    auto advance = [&](std::size_t i) {
      const std::size_t prev = i == 0 ? n - 1 : i - 1;
      for (int j = 0; j < 6; ++j) {
        const auto axes = SwingAxes(path.frame[i].unit[j]);
        const Eigen::Vector3d d = joints[i][j] - joints[prev][j];
        for (int k = 0; k < 2; ++k)
          r[j][k] = std::clamp(r[j][k] + 2.0 * axes[k].dot(d) / lambda, -1.0, 1.0);
      }
    };
    // Steady state: run through the test's motion once (the lead-in of a real test); the
    // closing step from the last sample to the first is part of a full turn.
    for (std::size_t i = 1; i < n; ++i) advance(i);
    advance(0);
    for (std::size_t i = 0; i < n; ++i) {
      if (i > 0) advance(i);
      const auto& f = path.frame[i];
      Eigen::Vector3d force = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
      for (int j = 0; j < 6; ++j) {
        const double load = path.gravity_N.empty() ? 0.0 : std::abs(path.gravity_N[i][j]);
        const double tau = p[0] + p[2] * load;  // N·m
        const auto axes = SwingAxes(f.unit[j]);
        const Eigen::Vector3d fj =
            -(tau / (1e-3 * f.length_mm[j])) * (r[j][0] * axes[0] + r[j][1] * axes[1]);
        force += fj;
        moment += f.lever_mm[j].cross(fj);
      }
      const Vector6d x = TensionsForWrench(f, force, moment);
      const Vector6d k = StrutCompliance(*s.physics, f, terms.k_stiff2_mm_per_N);
      out.ds_mm[i] += k.cwiseProduct(x);
    }
  }
  const char* Signature() const override {
    return "opposite in CW and CCW (odd), changing as a ramp after each reversal of a joint's "
           "swing";
  }
  int ShapeParameter() const override { return 1; }
  std::vector<double> ShapeGrid() const override { return {0.5, 1.0, 2.0, 4.0, 8.0}; }
};

}  // namespace

const HexapodEffect& JointFrictionEffect() {
  static const JointFriction e;
  return e;
}

}  // namespace km::hexapod
