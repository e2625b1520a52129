// The recipe for a new hexapod error effect (docs/architecture.md, "Where to add things"),
// followed once with a test-only effect that is not in the production list:
//
//   strut_scale: the actuators realise their commanded travel with a common scale error (a wrong
//   leadscrew pitch or encoder resolution shared by the six struts),
//     Δs_j = ε·(s_j − s_ref),   ε in ppm, s_ref the length at which the struts are homed.
//
// 1. The effect (name, parameter with unit, bounds and scale, Apply, Signature).
// 2. DBB data of a machine with the scale error, made without the effect's code: the simulator's
//    plain strut-error hook realises s_cmd + ε·(s_cmd − s_ref), runs the forward kinematics of
//    the true machine and measures the bar to the fixed ball.
// 3. The calibration with the effect recovers ε and closes the gap the kinematic calibration
//    leaves; on data without the scale error it finds ε ≈ 0. A first-principle check of Apply's
//    sign needs no simulator.
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/hexapod/effect_fit.h"
#include "analysis/hexapod/effects/effect.h"
#include "analysis/hexapod/effects/test_path.h"
#include "analysis/sim/hexapod_dbb_sim.h"
#include "tests/unit/hexapod/effects_fixture.h"

namespace km::hexapod {
namespace {

// Homing length of the struts: the scale error vanishes there. Its value only moves a part
// common to all struts, which the fitted strut offsets absorb.
constexpr double kHomeLengthMm = 850.0;

class StrutScale final : public HexapodEffect {
 public:
  const char* Name() const override { return "strut_scale"; }
  std::vector<EffectParameter> Parameters(const EffectSetup&) const override {
    return {{"scale_ppm", "ppm", 0.0, -2000.0, 2000.0, true, 10.0}};
  }
  void Apply(const TestPath& path, const double* p, const ModelTerms&, const EffectSetup&,
             Perturbation& out) const override {
    for (std::size_t i = 0; i < out.ds_mm.size(); ++i)
      out.ds_mm[i].array() += 1e-6 * p[0] * (path.strut_mm[i].array() - kHomeLengthMm);
  }
  const char* Signature() const override {
    return "a strut-length error proportional to each strut's travel from home: the circles "
           "change size and shape with the height and tilt of the platform, alike in CW and "
           "CCW and constant in time";
  }
};

const StrutScale kStrutScale;

// The strut values of a circle low in the workspace (long struts) and one high up (short).
PreparedTests Circle(double centre_z_mm) {
  auto t = test::CircleTest(dbb::Direction::kCcw, 36);
  t.centre_mm[2] = centre_z_mm;
  return PrepareTests(test::Pm600Like(), nullptr, {t}, {std::nullopt});
}

Perturbation ApplyScale(const PreparedTests& p, double scale_ppm) {
  Perturbation out;
  out.Reset(p.paths[0].pose.size());
  kStrutScale.Apply(p.paths[0], &scale_ppm, ModelTerms{}, p.setup, out);
  return out;
}

TEST(StrutScaleRecipe, ParametersHaveUnitsAndBoundsAroundZero) {
  const auto p = kStrutScale.Parameters(EffectSetup{});
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].unit, "ppm");
  EXPECT_LT(p[0].lower, 0.0);
  EXPECT_GT(p[0].upper, 0.0);
  EXPECT_TRUE(p[0].free);
  EXPECT_EQ(kStrutScale.Variants(EffectSetup{}).size(), 1u);
}

TEST(StrutScaleRecipe, PositiveScaleLengthensLongStrutsAndShortensShortOnes) {
  // A longer leadscrew pitch than the controller assumes: every strut overshoots its travel
  // from home, so struts beyond home are too long and struts short of it too short.
  const auto low = Circle(-1250.0);
  const auto high = Circle(-850.0);
  const auto dlow = ApplyScale(low, 50.0);
  const auto dhigh = ApplyScale(high, 50.0);
  for (std::size_t i = 0; i < dlow.ds_mm.size(); ++i) {
    for (int j = 0; j < 6; ++j) {
      const double s = low.paths[0].strut_mm[i][j];
      ASSERT_GT(s, kHomeLengthMm + 50.0) << "the low circle needs long struts";
      EXPECT_GT(dlow.ds_mm[i][j], 0.0);
      // 50 ppm of the travel beyond home: 1 µm per 20 mm.
      EXPECT_NEAR(dlow.ds_mm[i][j], (s - kHomeLengthMm) / 20.0 * 1e-3, 1e-12);
      ASSERT_LT(high.paths[0].strut_mm[i][j], kHomeLengthMm);
      EXPECT_LT(dhigh.ds_mm[i][j], 0.0);
    }
  }
  EXPECT_EQ(dlow.dl_mm[0], 0.0) << "the tool length is not touched";
}

// Table 2.1 plan (15 tests × CW/CCW, 180 samples, noise 0.3 µm) on a perturbed machine whose
// actuators realise s_cmd + ε·(s_cmd − s_ref): a plain hook, not the effect's code.
struct Data {
  HexapodGeometry nominal = test::Pm600Like();
  std::vector<dbb::DbbTest> tests;
};

Data Simulate(double scale_ppm, std::uint32_t seed) {
  Data d;
  const auto plan = sim::Table21Plan(180, true);
  sim::HexapodDbbSimOptions opt;
  opt.noise_um = 0.3;
  opt.seed = seed;
  opt.extra_strut_error = [scale_ppm](const Pose&, const Vector6d& s_cmd, double, dbb::Direction) {
    Vector6d e;
    for (int j = 0; j < 6; ++j) e[j] = scale_ppm * 1e-6 * (s_cmd[j] - 850.0);
    return e;
  };
  const auto truth = sim::PerturbGeometry(d.nominal, 0.3, 0.1, seed);
  d.tests = sim::SimulateHexapodDbbPlan(d.nominal, truth, plan, opt);
  return d;
}

struct Fits {
  EffectFitResult without, with;
};

Fits FitBoth(const Data& d) {
  const std::vector<std::optional<double>> starts(d.tests.size());
  const auto data =
      PrepareEffectFit(d.nominal, nullptr, d.tests, starts, CalibrationMethod::kAbsolute, 0);
  Fits f;
  f.without = FitWithEffects(data, StartingPoint(data, {}));
  f.with = FitWithEffects(data, StartingPoint(data, {&kStrutScale}));
  return f;
}

TEST(StrutScaleRecipe, CalibrationRecoversTheHiddenScale) {
  constexpr double kTruthPpm = 37.3;
  const auto f = FitBoth(Simulate(kTruthPpm, 11));
  ASSERT_TRUE(f.with.converged) << f.with.stop_reason;
  const double eps = f.with.effects[0].params[0].value;
  const double sigma = f.with.effect_sigma[0][0];
  std::printf("strut_scale: fitted %.3f ppm (truth %.1f), sigma %.3f ppm; rms %.3f -> %.3f um\n",
              eps, kTruthPpm, sigma, f.without.residual_rms_um, f.with.residual_rms_um);
  EXPECT_GT(sigma, 0.0);
  EXPECT_NEAR(eps, kTruthPpm, 3.0 * sigma);
  EXPECT_NEAR(eps, kTruthPpm, 0.05 * kTruthPpm);
  EXPECT_LT(f.with.residual_rms_um, 1.2 * 0.3) << "the gap closes to the noise";
  EXPECT_GT(f.without.residual_rms_um, 3.0 * f.with.residual_rms_um)
      << "the kinematic calibration alone leaves the scale error in its residuals";
}

TEST(StrutScaleRecipe, CleanDataGivesNoScale) {
  const auto f = FitBoth(Simulate(0.0, 12));
  ASSERT_TRUE(f.with.converged) << f.with.stop_reason;
  const double eps = f.with.effects[0].params[0].value;
  const double sigma = f.with.effect_sigma[0][0];
  std::printf("strut_scale on clean data: %.3f ppm, sigma %.3f ppm\n", eps, sigma);
  EXPECT_GT(sigma, 0.0);
  EXPECT_NEAR(eps, 0.0, 3.0 * sigma);
  EXPECT_LT(f.without.residual_rms_um, 1.2 * 0.3);
}

}  // namespace
}  // namespace km::hexapod
