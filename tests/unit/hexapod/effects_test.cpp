// Hexapod effects (docs/hexapod-effects.md): statics checked against the equilibrium written
// out independently, the gravity sag sign ([PM-600 report] §4), friction odd in the direction
// with a ramp after reversal ([Joint patent] figs. 10–12), tool length along the spindle axis,
// drift with time; calibration with effects recovers the truth and removes the CW/CCW
// dependence a friction-blind calibration shows ([Joint patent] fig. 15).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "analysis/hexapod/effect_fit.h"
#include "analysis/hexapod/effects/registry.h"
#include "analysis/hexapod/effects/test_path.h"
#include "analysis/hexapod/statics.h"
#include "analysis/sim/hexapod_dbb_sim.h"
#include "tests/unit/hexapod/effects_fixture.h"

namespace km::hexapod {
namespace {

using test::Pm600Physics;
using test::Simulate;

Pose PoseAt(double x, double y, double z, double a_deg = 0, double b_deg = 0) {
  Pose p;
  p.tip_mm = Eigen::Vector3d(x, y, z);
  p.abc_rad = Eigen::Vector3d(a_deg, b_deg, 0) * std::numbers::pi / 180.0;
  return p;
}

TEST(Statics, TensionsHoldThePlatformInEquilibrium) {
  const auto g = test::Pm600Like();
  const auto phys = Pm600Physics();
  const Pose pose = PoseAt(40, -30, -1050, 12, -7);
  const double l = 120.0;
  const auto f = StrutFrameAt(g, pose, l);
  const Vector6d axial = GravityAxialForces(phys, f, pose, l);
  // Equilibrium written out: platform weight at its centre of gravity, the strut weights' parts
  // perpendicular to the struts at the platform joints, and the strut pulls −x_j l_j.
  const auto joints = PlatformJointsInMachine(g, pose, l);
  Eigen::Vector3d force = phys.platform_mass_kg * phys.g_m_s2;
  const Eigen::Vector3d cog =
      pose.tip_mm + RotationABC(pose.abc_rad) * (phys.platform_cog_mm + Eigen::Vector3d(0, 0, l));
  Eigen::Vector3d moment = (cog - pose.tip_mm).cross(force);
  for (int j = 0; j < 6; ++j) {
    const Eigen::Vector3d strut = joints[j] - g.base_joints_mm[j];
    const double len = strut.norm();
    const Eigen::Vector3d u = strut / len;
    const double w = (12.0 * (len - 150.0 - 500.0) + 6.0 * len - 18.0 * 100.0) / len;
    const Eigen::Vector3d wg = w * phys.g_m_s2;
    const Eigen::Vector3d perp = wg - wg.dot(u) * u;
    const double tension = axial[j] + 27.0 * phys.g_m_s2.dot(u);
    const Eigen::Vector3d pull = -tension * u;
    force += perp + pull;
    moment += (joints[j] - pose.tip_mm).cross(perp + pull);
  }
  EXPECT_LT(force.norm(), 1e-9);
  EXPECT_LT(moment.norm(), 1e-6);
}

TEST(GravityDeflection, StrutsInTensionAndTheToolSags) {
  const auto g = test::Pm600Like();
  const auto phys = Pm600Physics();
  for (double tilt : {0.0, 15.0, -20.0}) {
    const Pose pose = PoseAt(0, 0, -1050, tilt, 0);
    const double l = 104.255;
    const auto f = StrutFrameAt(g, pose, l);
    const Vector6d axial = GravityAxialForces(phys, f, pose, l);
    // Untilted, the platform hangs from all six struts; tilted, some may be pushed.
    if (tilt == 0.0) {
      for (int j = 0; j < 6; ++j) EXPECT_GT(axial[j], 100.0) << "strut " << j;
    }
    const Vector6d ds = StrutCompliance(phys, f, 1.52e-5).cwiseProduct(axial);
    const Vector6d s = InverseKinematics(g, pose, l);
    const auto real = ForwardKinematics(g, s + ds, l, pose);
    if (tilt == 0.0) {
      EXPECT_LT(real.pose.tip_mm.z() - pose.tip_mm.z(), -1e-3) << "the tool must sag (−z)";
      EXPECT_LT(std::hypot(real.pose.tip_mm.x(), real.pose.tip_mm.y()), 1e-3);
    }
    // Size: a few µm to tens of µm on a PM-600-class machine ([PM-600 report] table 4.5).
    EXPECT_GT(ds.cwiseAbs().maxCoeff(), 1e-3);
    EXPECT_LT(ds.cwiseAbs().maxCoeff(), 0.05);
  }
}

// A single test prepared for the effects.
PreparedTests OneCircle(dbb::Direction dir, const MachinePhysics& phys, int n = 720) {
  return PrepareTests(test::Pm600Like(), &phys, {test::CircleTest(dir, n)}, {0.0});
}

TEST(JointFriction, OppositeInCwAndCcwAndRampsAfterReversal) {
  const auto phys = Pm600Physics();
  const auto* fr = FindHexapodEffect("joint_friction");
  ASSERT_NE(fr, nullptr);
  const auto ccw = OneCircle(dbb::Direction::kCcw, phys);
  const auto cw = OneCircle(dbb::Direction::kCw, phys);
  ActiveEffect a{fr, fr->Parameters(ccw.setup)};
  a.params[1].value = 2.0;  // ramp_mm
  Perturbation pc, pw;
  ApplyEffects({a}, ccw.paths[0], ccw.setup, pc);
  ApplyEffects({a}, cw.paths[0], cw.setup, pw);
  // CW sample k sits at angle −k·0.5° = the CCW sample (720 − k) mod 720.
  double odd = 0.0, even = 0.0;
  for (int k = 0; k < 720; ++k) {
    const Vector6d c = pc.ds_mm[static_cast<std::size_t>(k)];
    const Vector6d w = pw.ds_mm[static_cast<std::size_t>((720 - k) % 720)];
    odd += (c - w).squaredNorm();
    even += (c + w).squaredNorm();
  }
  EXPECT_GT(odd, 0.0);
  // Away from the ramps the friction flips exactly; the ramps make the even part small.
  EXPECT_LT(even, 0.05 * odd);
  // After a reversal the strut deflection changes over several samples (a ramp), not in one.
  std::vector<double> steps;
  for (std::size_t k = 1; k < pc.ds_mm.size(); ++k)
    steps.push_back((pc.ds_mm[k] - pc.ds_mm[k - 1]).cwiseAbs().maxCoeff());
  const double range = [&] {
    double lo = 1e9, hi = -1e9;
    for (const auto& d : pc.ds_mm) {
      lo = std::min(lo, d.minCoeff());
      hi = std::max(hi, d.maxCoeff());
    }
    return hi - lo;
  }();
  EXPECT_LT(*std::max_element(steps.begin(), steps.end()), 0.5 * range);
}

TEST(ToolLengthError, MovesTheTipAlongTheSpindleAxis) {
  const auto phys = Pm600Physics();
  const auto prepared = OneCircle(dbb::Direction::kCcw, phys, 16);
  const auto* tl = FindHexapodEffect("tool_length_error");
  ActiveEffect a{tl, tl->Parameters(prepared.setup)};
  ASSERT_EQ(a.params.size(), 1u);
  EXPECT_EQ(a.params[0].name, "error_um[104.255]");
  a.params[0].value = -62.0;
  Perturbation p;
  ApplyEffects({a}, prepared.paths[0], prepared.setup, p);
  const auto& path = prepared.paths[0];
  const Pose pose = path.pose[3];
  const auto real = ForwardKinematics(test::Pm600Like(), path.strut_mm[3] + p.ds_mm[3],
                                      104.255 + p.dl_mm[3], pose);
  // A shorter real tool: the tip stands 62 µm higher (+z) at an untilted pose.
  EXPECT_NEAR(real.pose.tip_mm.z() - pose.tip_mm.z(), 0.062, 1e-9);
}

TEST(CalibrationWithEffects, RecoversGravityAndToolLength) {
  const auto s = Simulate(
      {{"gravity_deflection", {{0, 1.52e-5}}}, {"tool_length_error", {{0, -62.0}, {1, 0.0}}}});
  const auto data =
      PrepareEffectFit(s.nominal, &s.phys, s.tests, s.starts, CalibrationMethod::kAbsolute, 0);
  auto start = StartingPoint(
      data, {FindHexapodEffect("gravity_deflection"), FindHexapodEffect("tool_length_error")});
  const auto fit = FitWithEffects(data, start);
  EXPECT_TRUE(fit.converged);
  EXPECT_NEAR(fit.residual_rms_um, 0.3, 0.03);
  EXPECT_NEAR(fit.effects[0].params[0].value, 1.52e-5, 0.02 * 1.52e-5);
  EXPECT_NEAR(fit.effects[1].params[0].value, -62.0, 4.0 * fit.effect_sigma[1][0] + 0.5);
  EXPECT_NEAR(fit.effects[1].params[1].value, 0.0, 4.0 * fit.effect_sigma[1][1] + 0.5);
  EXPECT_GT(fit.effect_sigma[0][0], 0.0);
}

TEST(CalibrationWithEffects, FrictionBlindCalibrationDependsOnTheDirection) {
  // [Joint patent] fig. 15: kinematic parameters from CW tests and from CCW tests disagree when
  // joint friction is ignored, and agree when it is modelled.
  const auto s = Simulate({{"joint_friction", {{0, 8.88}, {1, 2.0}}}});
  std::vector<dbb::DbbTest> ccw, cw;
  std::vector<std::optional<double>> sc, sw;
  for (std::size_t i = 0; i < s.tests.size(); ++i) {
    (s.tests[i].direction == dbb::Direction::kCcw ? ccw : cw).push_back(s.tests[i]);
    (s.tests[i].direction == dbb::Direction::kCcw ? sc : sw).push_back(s.starts[i]);
  }
  auto strut_gap = [&](bool with_friction) {
    std::vector<const HexapodEffect*> eff;
    if (with_friction) eff.push_back(FindHexapodEffect("joint_friction"));
    ParameterVector k[2];
    double sigma = 0.0;
    for (int d = 0; d < 2; ++d) {
      const auto data = PrepareEffectFit(s.nominal, &s.phys, d == 0 ? ccw : cw, d == 0 ? sc : sw,
                                         CalibrationMethod::kAbsolute, 0);
      const auto fit = FitWithEffects(data, StartingPoint(data, eff));
      k[d] = fit.k_um;
      sigma = std::max(sigma, fit.k_sigma_um.head<6>().maxCoeff());
    }
    return std::make_pair((k[0] - k[1]).head<6>().cwiseAbs().maxCoeff(), sigma);
  };
  const auto [blind, blind_sigma] = strut_gap(false);
  const auto [modelled, modelled_sigma] = strut_gap(true);
  // The σ are test-level (jackknife over the tests): the friction a blind calibration leaves
  // in its residuals is systematic within each test, so its σ are honest about it and large.
  EXPECT_GT(blind, 2.0 * blind_sigma) << "a friction-blind calibration depends on direction";
  EXPECT_GT(blind, 20.0 * modelled) << "modelling friction removes the dependence";
  EXPECT_GT(blind_sigma, 3.0 * modelled_sigma) << "the blind fit's σ shows its misfit";
  EXPECT_LT(modelled, 6.0 * modelled_sigma) << "modelling friction removes the dependence";
  std::printf("strut offsets CCW - CW: blind %.2f um (sigma %.2f), modelled %.2f um (sigma %.2f)\n",
              blind, blind_sigma, modelled, modelled_sigma);
}

}  // namespace
}  // namespace km::hexapod
