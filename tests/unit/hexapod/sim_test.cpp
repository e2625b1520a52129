// DBB simulation of a hexapod (analysis/sim): perfect machine gives a perfect trace; a rigid
// translation of the base is seen in absolute (jig) set-up but not in the conventional one;
// independent closed-form check of the bar reading; noise statistics; strut-error hook.
#include <cmath>
#include <numbers>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "analysis/hexapod/dbb_geometry.h"
#include "analysis/sim/hexapod_dbb_sim.h"
#include "tests/unit/hexapod/pm600_fixture.h"

namespace km::sim {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(HexapodDbbSim, Table21PlanShape) {
  const auto plan = Table21Plan(360, true);
  ASSERT_EQ(plan.size(), 30u);
  std::set<std::string> ids;
  int cones = 0, tilted = 0;
  for (const auto& s : plan) {
    ids.insert(s.test_id);
    cones += s.z_offset_mm != 0.0;
    tilted += s.tilt_deg.norm() > 0.0;
    EXPECT_EQ(s.samples_per_turn, 360);
  }
  EXPECT_EQ(ids.size(), 15u);
  EXPECT_EQ(cones, 10);  // level-2 rows, both directions
  EXPECT_GT(tilted, 0);
  EXPECT_EQ(VerificationPlan(90).size(), 8u);
}

TEST(HexapodDbbSim, PerfectMachineGivesZeroDeviation) {
  const auto g = hexapod::test::Pm600Like();
  for (bool absolute : {true, false}) {
    HexapodDbbSimOptions opt;
    opt.absolute = absolute;
    for (const auto& spec : Table21Plan(72, true)) {
      const auto t = SimulateHexapodDbb(g, g, spec, opt, 1);
      ASSERT_EQ(t.dr_um.size(), 73u);
      EXPECT_EQ(t.fixed_ball_mm.has_value(), absolute);
      for (double dr : t.dr_um) EXPECT_NEAR(dr, 0.0, 1e-6) << spec.test_id;
      if (spec.direction == dbb::Direction::kCw) {
        EXPECT_LT(t.angle_deg.back(), -359.0);
      }
    }
  }
}

TEST(HexapodDbbSim, RigidBaseTranslationMatchesClosedForm) {
  // True base = nominal base shifted by t: the real tool tip is the commanded one plus t, so
  // the bar reads |M(θ) + t − F| (independent closed form) in the jig set-up, and nothing in the
  // conventional set-up (the fixed ball is seated where the shifted spindle stands).
  const auto nominal = hexapod::test::Pm600Like();
  for (unsigned seed : {3u, 4u, 5u}) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-0.3, 0.3);
    const Eigen::Vector3d t(u(rng), u(rng), u(rng));
    auto truth = nominal;
    for (auto& q : truth.base_joints_mm) q += t;
    HexapodDbbSpec spec = Table21Plan(90, false)[6];  // cone test "g", tilted
    ASSERT_EQ(spec.test_id, "g");
    HexapodDbbSimOptions opt;
    const auto abs = SimulateHexapodDbb(nominal, truth, spec, opt, 1);
    for (std::size_t i = 0; i < abs.dr_um.size(); ++i) {
      const double th = abs.angle_deg[i] * kPi / 180.0;
      const Eigen::Vector3d M = spec.centre_mm + Eigen::Vector3d(0, 0, spec.z_offset_mm) +
                                spec.radius_mm * Eigen::Vector3d(std::cos(th), std::sin(th), 0);
      const double expect = 1000.0 * ((M + t - spec.centre_mm).norm() - spec.bar_length_mm);
      EXPECT_NEAR(abs.dr_um[i], expect, 1e-5);
    }
    opt.absolute = false;
    const auto conv = SimulateHexapodDbb(nominal, truth, spec, opt, 1);
    for (double dr : conv.dr_um) EXPECT_NEAR(dr, 0.0, 1e-5);
  }
}

TEST(HexapodDbbSim, NoiseHasTheRequestedSigmaAndIsSeeded) {
  const auto g = hexapod::test::Pm600Like();
  HexapodDbbSimOptions opt;
  opt.noise_um = 0.3;
  auto spec = Table21Plan(2000, false)[0];
  const auto a = SimulateHexapodDbb(g, g, spec, opt, 17);
  const auto b = SimulateHexapodDbb(g, g, spec, opt, 17);
  const auto c = SimulateHexapodDbb(g, g, spec, opt, 18);
  double s2 = 0.0;
  for (double dr : a.dr_um) s2 += dr * dr;
  EXPECT_NEAR(std::sqrt(s2 / a.dr_um.size()), 0.3, 0.03);
  EXPECT_EQ(a.dr_um, b.dr_um);
  EXPECT_NE(a.dr_um, c.dr_um);
}

TEST(HexapodDbbSim, StrutErrorHookActsLikeAStrutOffset) {
  const auto nominal = hexapod::test::Pm600Like();
  auto truth = nominal;
  truth.strut_offset_mm = {0.02, -0.03, 0.01, 0.04, -0.05, 0.0};
  HexapodDbbSimOptions with_hook;
  with_hook.extra_strut_error = [&](const hexapod::Pose&, const hexapod::Vector6d&, double,
                                    dbb::Direction) {
    hexapod::Vector6d e;
    for (int j = 0; j < 6; ++j) e[j] = truth.strut_offset_mm[j];
    return e;
  };
  for (const auto& spec : Table21Plan(60, false)) {
    const auto a = SimulateHexapodDbb(nominal, truth, spec, HexapodDbbSimOptions{}, 1);
    const auto b = SimulateHexapodDbb(nominal, nominal, spec, with_hook, 1);
    double worst = 0.0, size = 0.0;
    for (std::size_t i = 0; i < a.dr_um.size(); ++i) {
      worst = std::max(worst, std::abs(a.dr_um[i] - b.dr_um[i]));
      size = std::max(size, std::abs(a.dr_um[i]));
    }
    EXPECT_LT(worst, 1e-6) << spec.test_id;
    EXPECT_GT(size, 1.0) << spec.test_id;  // the offsets are visible at all
  }
}

TEST(HexapodDbbSim, PerturbGeometryStaysWithinBoundsAndIsSeeded) {
  const auto g = hexapod::test::Pm600Like();
  const auto a = PerturbGeometry(g, 0.3, 0.1, 9);
  const auto b = PerturbGeometry(g, 0.3, 0.1, 9);
  for (int j = 0; j < 6; ++j) {
    EXPECT_LE((a.base_joints_mm[j] - g.base_joints_mm[j]).cwiseAbs().maxCoeff(), 0.3);
    EXPECT_LE(std::abs(a.strut_offset_mm[j]), 0.1);
    EXPECT_EQ(a.base_joints_mm[j], b.base_joints_mm[j]);
  }
}

}  // namespace
}  // namespace km::sim
