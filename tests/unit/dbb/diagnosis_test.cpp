// Diagnosis of serial-machine DBB pairs: each effect alone is ranked first and recovered; mixed
// effects are separated; a perfect machine yields nothing (apart from an injected centre offset).
#include "analysis/dbb/diagnosis.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "tests/unit/dbb/dbb_test_util.h"

namespace km::dbb {
namespace {

using serial_effects::EffectId;
using test::Describe;

struct Case {
  EffectId id;
  std::vector<double> params;
  double truth;  // reported value expected
};

const DiagnosisEntry* Find(const DiagnosisResult& r, const std::string& name) {
  for (const auto& e : r.named)
    if (e.effect == name) return &e;
  return nullptr;
}

class SingleEffect : public ::testing::TestWithParam<Case> {};

TEST_P(SingleEffect, RankedFirstAndRecovered) {
  const Case c = GetParam();
  for (unsigned seed : {1u, 2u, 3u}) {
    SerialDbbSimOptions o;
    o.seed = seed;
    o.noise_um = 0.1;
    o.fixed_ball_offset_um = {0.0, 0.0};
    o.effects = {{c.id, c.params}};
    const auto r = test::DiagnoseTests(test::SimulatePair(o));
    const std::string name = serial_effects::EffectName(c.id, 'x', 'y');
    ASSERT_FALSE(r.named.empty()) << name << " seed " << seed;
    EXPECT_EQ(r.named.front().effect, name) << Describe(r);
    const DiagnosisEntry* e = Find(r, name);
    ASSERT_NE(e, nullptr) << Describe(r);
    const double tol = std::max(0.05 * std::abs(c.truth), 1e-9);
    EXPECT_NEAR(e->value[0], c.truth, tol) << name << " seed " << seed << ": " << Describe(r);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Effects, SingleEffect,
    ::testing::Values(
        Case{EffectId::kSquareness, {20.0}, 20.0}, Case{EffectId::kSquareness, {-30.0}, -30.0},
        Case{EffectId::kScaleMismatch, {25.0}, 25.0}, Case{EffectId::kServoMismatch, {0.3}, 0.3},
        Case{EffectId::kServoMismatch, {-0.3}, -0.3}, Case{EffectId::kBacklashU, {3.0}, 3.0},
        Case{EffectId::kBacklashV, {-2.5}, -2.5}, Case{EffectId::kReversalSpikeU, {4.0, 2.0}, 4.0},
        Case{EffectId::kReversalSpikeV, {3.0, 1.0}, 3.0}, Case{EffectId::kLateralPlayU, {2.0}, 2.0},
        Case{EffectId::kLateralPlayV, {2.0}, 2.0}, Case{EffectId::kStraightnessU, {3.0}, 3.0},
        Case{EffectId::kStraightnessV, {-3.0}, -3.0},
        Case{EffectId::kCyclicErrorU, {1.0, 0.5, 10.0}, std::hypot(1.0, 0.5)},
        Case{EffectId::kCyclicErrorV, {-0.8, 0.0, 16.0}, 0.8},
        Case{EffectId::kStickSlip, {1.0, 0.5}, 1.0}));

TEST(Diagnosis, PerfectMachineNamesNothing) {
  for (unsigned seed : {11u, 12u, 13u, 14u, 15u}) {
    SerialDbbSimOptions o;
    o.seed = seed;
    o.noise_um = 0.2;
    const auto r = test::DiagnoseTests(test::SimulatePair(o));
    EXPECT_TRUE(r.named.empty()) << "seed " << seed << ": " << Describe(r);
  }
}

TEST(Diagnosis, PerfectMachineSingleTraceNamesNothing) {
  for (unsigned seed : {16u, 17u, 18u}) {
    SerialDbbSimOptions o;
    o.seed = seed;
    o.noise_um = 0.2;
    o.step_deg = 0.5;
    const auto r = test::DiagnoseTests(test::SimulatePair(o, /*both=*/false));
    EXPECT_TRUE(r.named.empty()) << "seed " << seed << ": " << Describe(r);
  }
}

TEST(Diagnosis, ConeTestAndAbsoluteModeRecoverInPlaneValues) {
  // Cone test of [PM-600 report]: R = 144 mm, bar 150 mm, moving-ball plane 42 mm above the fixed
  // ball; the bar sees (R / R_DBB)·Δr, the diagnosis scales back to the in-plane error.
  SerialDbbSimOptions o;
  o.seed = 61;
  o.radius_mm = 144.0;
  o.bar_length_mm = 150.0;
  o.z_offset_mm = 42.0;
  o.absolute = true;
  o.effects = {{EffectId::kBacklashU, {4.0}}, {EffectId::kScaleMismatch, {30.0}}};
  const auto r = test::DiagnoseTests(test::SimulatePair(o));
  const auto* bl = Find(r, "backlash_x");
  const auto* sc = Find(r, "scale_mismatch");
  ASSERT_TRUE(bl && sc) << Describe(r);
  EXPECT_NEAR(bl->value[0], 4.0, 0.2);
  EXPECT_NEAR(sc->value[0], 30.0, 1.5);
  EXPECT_EQ(Find(r, "centre_offset"), nullptr) << Describe(r);  // fixed ball measured exactly
}

TEST(Diagnosis, UncertaintyMatchesScatterOverSeeds) {
  // The reported standard uncertainty of a value agrees with its scatter over noise
  // realisations (within the sampling error of a 12-sample standard deviation).
  std::vector<double> v;
  double u = 0.0;
  for (unsigned seed = 100; seed < 112; ++seed) {
    SerialDbbSimOptions o;
    o.seed = seed;
    o.noise_um = 0.5;
    o.step_deg = 0.5;
    o.effects = {{EffectId::kSquareness, {40.0}}};
    const auto r = test::DiagnoseTests(test::SimulatePair(o));
    const auto* e = Find(r, "squareness");
    ASSERT_NE(e, nullptr);
    v.push_back(e->value[0]);
    u += e->uncertainty[0] / 12.0;
  }
  double m = 0.0, s = 0.0;
  for (double x : v) m += x / 12.0;
  for (double x : v) s += (x - m) * (x - m) / 11.0;
  EXPECT_NEAR(std::sqrt(s), u, 0.5 * u);
  EXPECT_NEAR(m, 40.0, 3.0 * u);
}

TEST(Diagnosis, CentreOffsetOnlyWhenInjected) {
  for (unsigned seed : {21u, 22u, 23u}) {
    SerialDbbSimOptions o;
    o.seed = seed;
    o.noise_um = 0.2;
    o.effects = {{EffectId::kCentreOffset, {12.0, -7.0}}};
    const auto r = test::DiagnoseTests(test::SimulatePair(o));
    ASSERT_EQ(r.named.size(), 1u) << Describe(r);
    EXPECT_EQ(r.named[0].effect, "centre_offset");
    EXPECT_NEAR(r.named[0].value[0], 12.0, 0.1);
    EXPECT_NEAR(r.named[0].value[1], -7.0, 0.1);
  }
}

TEST(Diagnosis, ThreeMixedEffectsSeparated) {
  for (unsigned seed : {31u, 32u, 33u}) {
    SerialDbbSimOptions o;
    o.seed = seed;
    o.effects = {{EffectId::kSquareness, {25.0}},
                 {EffectId::kServoMismatch, {0.25}},
                 {EffectId::kBacklashU, {3.0}}};
    const auto r = test::DiagnoseTests(test::SimulatePair(o));
    const auto* sq = Find(r, "squareness");
    const auto* sm = Find(r, "servo_mismatch");
    const auto* bl = Find(r, "backlash_x");
    ASSERT_TRUE(sq && sm && bl) << Describe(r);
    EXPECT_NEAR(sq->value[0], 25.0, 1.25);
    EXPECT_NEAR(sm->value[0], 0.25, 0.0125);
    EXPECT_NEAR(bl->value[0], 3.0, 0.15);
    EXPECT_EQ(r.named.size(), 3u) << Describe(r);
  }
}

TEST(Diagnosis, SingleTraceReportsConfoundedEffects) {
  SerialDbbSimOptions o;
  o.seed = 41;
  o.effects = {{EffectId::kSquareness, {30.0}}};
  const auto r = test::DiagnoseTests(test::SimulatePair(o, /*both=*/false));
  ASSERT_FALSE(r.named.empty());
  EXPECT_EQ(r.named.front().effect, "squareness");
  bool found = false;
  for (const auto& s : r.not_identifiable) found |= s.rfind("servo_mismatch", 0) == 0;
  EXPECT_TRUE(found);
}

TEST(Diagnosis, PlaneLettersFollowThePlane) {
  SerialDbbSimOptions o;
  o.seed = 51;
  o.plane = Plane::kYZ;
  o.effects = {{EffectId::kBacklashV, {3.0}}};
  const auto r = test::DiagnoseTests(test::SimulatePair(o));
  ASSERT_FALSE(r.named.empty());
  EXPECT_EQ(r.named.front().effect, "backlash_z");
}

}  // namespace
}  // namespace km::dbb
