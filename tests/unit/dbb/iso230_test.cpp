// ISO 230-4 figures against closed forms of simulated traces (noise-free):
//   scale mismatch Δk and servo mismatch Δτ give Δr = A cos 2θ ± B sin 2θ (+ for ccw),
//   A = Δk·1e-6·R/2, B = V·Δτ/2  ⇒  G = 2√(A² + B²) per trace, H = 2B, G(b) = 2√(A² + B²)
//   (union of A cos 2θ ± B sin 2θ has the same extremes), F_max = ρ + √(A² + B²).
#include "analysis/dbb/iso230.h"

#include <cmath>

#include <gtest/gtest.h>

#include "analysis/core/errors.h"
#include "tests/unit/dbb/dbb_test_util.h"

namespace km::dbb {
namespace {

using serial_effects::EffectId;

TEST(Iso230, ClosedFormsForScaleAndServoMismatch) {
  for (double dk : {20.0, -35.0}) {
    for (double dtau : {0.1, -0.2}) {
      SerialDbbSimOptions o;
      o.noise_um = 0.0;
      o.step_deg = 0.05;
      o.fixed_ball_offset_um = {4.0, -3.0};
      o.effects = {{EffectId::kScaleMismatch, {dk}},
                   {EffectId::kServoMismatch, {dtau}},
                   {EffectId::kRadiusError, {2.5}}};
      const auto tests = test::SimulatePair(o);
      const double a = std::abs(dk) * 1e-6 * 150000.0 / 2.0;
      const double b = std::abs(1000.0 / 60.0 * dtau / 2.0);
      const double amp = std::hypot(a, b);
      const auto ccw = AnalyzeCircularTest(tests[0]);
      const auto cw = AnalyzeCircularTest(tests[1]);
      for (const auto* r : {&ccw, &cw}) {
        const auto f = ComputeIso230(*r);
        EXPECT_NEAR(f.circular_deviation_um, 2.0 * amp, 1e-3);
        EXPECT_NEAR(f.radial_deviation_max_um, 2.5 + amp, 1e-3);
        EXPECT_NEAR(f.radial_deviation_min_um, 2.5 - amp, 1e-3);
        EXPECT_EQ(f.radial_reference, "least_squares_centre");
      }
      const auto p = ComputeIso230Pair(cw, ccw);
      EXPECT_NEAR(p.circular_hysteresis_um, 2.0 * b, 2e-3);
      EXPECT_NEAR(p.bidirectional_circular_deviation_um, 2.0 * amp, 1e-3);
      EXPECT_THROW(ComputeIso230Pair(ccw, cw), km::InvalidInput);
    }
  }
}

TEST(Iso230, HysteresisInterpolatesOntoCommonAngles) {
  // cw samples fall between the ccw ones (different step and start): H = 2B still.
  SerialDbbSimOptions o;
  o.noise_um = 0.0;
  o.effects = {{EffectId::kServoMismatch, {0.3}}};
  o.step_deg = 0.1;
  o.direction = Direction::kCcw;
  const DbbTest ccw = SimulateSerialDbbTest(o);
  o.direction = Direction::kCw;
  o.step_deg = 0.07;
  o.start_deg = 0.033;
  const DbbTest cw = SimulateSerialDbbTest(o);
  const auto p = ComputeIso230Pair(AnalyzeCircularTest(cw), AnalyzeCircularTest(ccw));
  const double b = 1000.0 / 60.0 * 0.3 / 2.0;
  EXPECT_NEAR(p.circular_hysteresis_um, 2.0 * b, 2e-3);
  EXPECT_NEAR(p.bidirectional_circular_deviation_um, 2.0 * b, 2e-3);
}

TEST(Iso230, AbsoluteModeMeasuresFromTheNominalCentre) {
  SerialDbbSimOptions o;
  o.noise_um = 0.0;
  o.absolute = true;
  o.fixed_ball_offset_um = {0.0, 0.0};
  o.effects = {{EffectId::kCentreOffset, {6.0, 8.0}}, {EffectId::kRadiusError, {-1.0}}};
  const auto tests = test::SimulatePair(o, false);
  const auto r = AnalyzeCircularTest(tests[0]);
  ASSERT_EQ(r.mode, Mode::kAbsolute);
  const auto f = ComputeIso230(r);
  // Δr = 6 cos θ + 8 sin θ − 1  ⇒  F ∈ [−11, 9] about the nominal centre; G ≈ 0.
  EXPECT_EQ(f.radial_reference, "nominal_centre");
  EXPECT_NEAR(f.radial_deviation_max_um, 9.0, 1e-3);
  EXPECT_NEAR(f.radial_deviation_min_um, -11.0, 1e-3);
  EXPECT_LT(f.circular_deviation_um, 1e-3);
  // The reconstruction of the deviation about the nominal centre inverts the planar fit.
  const auto dev = DeviationAboutNominalCentre(r);
  const auto turn = SelectOneTurn(tests[0]);
  ASSERT_EQ(dev.size(), turn.dr_um.size());
  for (std::size_t i = 0; i < dev.size(); i += 97) EXPECT_NEAR(dev[i], turn.dr_um[i], 1e-6);
}

}  // namespace
}  // namespace km::dbb
