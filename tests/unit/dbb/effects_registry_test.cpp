// Effect registry: names, parameter bookkeeping, Jet evaluation = double evaluation, and the
// radial signatures against the closed forms documented in the model headers.
#include "analysis/serial_effects/registry.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <ceres/jet.h>
#include <gtest/gtest.h>

namespace km::serial_effects {
namespace {

std::vector<double> Params(EffectId id, double value) {
  const auto& info = Info(id);
  std::vector<double> p(static_cast<std::size_t>(info.num_linear), 0.0);
  p[0] = value;
  p.insert(p.end(), info.default_shape.begin(), info.default_shape.end());
  return p;
}

TEST(EffectRegistry, NamesAndParameterCounts) {
  const auto& all = AllEffects();
  ASSERT_EQ(all.size(), static_cast<std::size_t>(EffectId::kCount));
  for (const auto& info : all) {
    EXPECT_EQ(static_cast<int>(info.param_names.size()), info.num_params) << info.base_name;
    EXPECT_EQ(static_cast<int>(info.default_shape.size()), info.num_params - info.num_linear);
    EffectId back;
    ASSERT_TRUE(EffectIdFromName(EffectName(info.id, 'y', 'z'), 'y', 'z', &back));
    EXPECT_EQ(back, info.id);
  }
  EXPECT_EQ(EffectName(EffectId::kBacklashU), "backlash_x");
  EXPECT_EQ(EffectName(EffectId::kCyclicErrorV, 'z', 'x'), "cyclic_error_x");
  EXPECT_EQ(EffectName(EffectId::kServoMismatch), "servo_mismatch");
  EXPECT_EQ(Info(EffectId::kSquareness).unit, "um/m");
  EXPECT_EQ(Info(EffectId::kScaleMismatch).unit, "ppm");
  EXPECT_EQ(Info(EffectId::kServoMismatch).unit, "ms");
}

TEST(EffectRegistry, JetEvaluationMatchesDoubleAndFiniteDifferences) {
  using J = ceres::Jet<double, 4>;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.05, 6.2);
  EffectContext ctx;
  ctx.direction = -1;
  for (const auto& info : AllEffects()) {
    auto p = Params(info.id, 1.7);
    if (info.num_linear > 1) p[1] = -0.6;
    for (int trial = 0; trial < 20; ++trial) {
      const double th = u(rng);
      double e[2];
      PositionError(info.id, ctx, th, p.data(), e);
      std::vector<J> pj;
      for (std::size_t k = 0; k < p.size(); ++k) pj.push_back(J(p[k], static_cast<int>(k % 3) + 1));
      J ej[2];
      PositionErrorT<J>(info.id, ctx, MakeAngle(J(th, 0)), pj.data(), ej);
      EXPECT_NEAR(ej[0].a, e[0], 1e-12) << info.base_name;
      EXPECT_NEAR(ej[1].a, e[1], 1e-12) << info.base_name;
      // d e / d θ against a central difference (away from discontinuities: skip steps).
      const double h = 1e-6;
      double ep[2], em[2];
      PositionError(info.id, ctx, th + h, p.data(), ep);
      PositionError(info.id, ctx, th - h, p.data(), em);
      for (int c = 0; c < 2; ++c) {
        const double fd = (ep[c] - em[c]) / (2.0 * h);
        if (std::abs(ep[c] - em[c]) < 1e-3) {
          EXPECT_NEAR(ej[c].v[0], fd, 1e-4) << info.base_name;
        }
      }
    }
  }
}

TEST(EffectRegistry, RadialBasisEqualsSignaturesOfUnitParameters) {
  EffectContext ctx;
  ctx.direction = -1;
  for (const auto& info : AllEffects()) {
    for (double th = 0.05; th < 6.28; th += 0.41) {
      double cols[kMaxLinearParams];
      RadialBasis(info.id, ctx, MakeAngle(th), info.default_shape.data(), cols);
      for (int j = 0; j < info.num_linear; ++j) {
        std::vector<double> p(static_cast<std::size_t>(info.num_linear), 0.0);
        p[static_cast<std::size_t>(j)] = 1.0;
        p.insert(p.end(), info.default_shape.begin(), info.default_shape.end());
        EXPECT_NEAR(cols[j], RadialSignature(info.id, ctx, th, p.data()), 1e-12) << info.base_name;
      }
    }
  }
}

TEST(EffectRegistry, RadialSignaturesMatchClosedForms) {
  EffectContext ctx;
  ctx.radius_mm = 200.0;
  ctx.feed_mm_min = 3000.0;  // V = 50 mm/s
  for (int s : {1, -1}) {
    ctx.direction = s;
    for (double th = 0.013; th < 6.28; th += 0.37) {
      const double sq = RadialSignature(EffectId::kSquareness, ctx, th,
                                        Params(EffectId::kSquareness, 10.0).data());
      EXPECT_NEAR(sq, -10.0e-6 * 200000.0 / 2.0 * std::sin(2 * th), 1e-9);
      const double sc = RadialSignature(EffectId::kScaleMismatch, ctx, th,
                                        Params(EffectId::kScaleMismatch, 10.0).data());
      EXPECT_NEAR(sc, 10.0e-6 * 200000.0 / 2.0 * std::cos(2 * th), 1e-9);
      const double sm = RadialSignature(EffectId::kServoMismatch, ctx, th,
                                        Params(EffectId::kServoMismatch, 0.2).data());
      EXPECT_NEAR(sm, s * 50.0 * 0.2 / 2.0 * std::sin(2 * th), 1e-9);
      const double bl =
          RadialSignature(EffectId::kBacklashU, ctx, th, Params(EffectId::kBacklashU, 4.0).data());
      EXPECT_NEAR(bl, 2.0 * s * (std::sin(th) > 0 ? 1 : -1) * std::cos(th), 1e-9);
      const double st = RadialSignature(EffectId::kStraightnessU, ctx, th,
                                        Params(EffectId::kStraightnessU, 3.0).data());
      EXPECT_NEAR(st, 3.0 * std::pow(std::sin(th), 3), 1e-9);
      const double lp = RadialSignature(EffectId::kLateralPlayU, ctx, th,
                                        Params(EffectId::kLateralPlayU, 2.0).data());
      EXPECT_NEAR(lp, s * 1.0 * std::abs(std::sin(th)), 1e-9);
      const double lag =
          RadialSignature(EffectId::kServoLag, ctx, th, Params(EffectId::kServoLag, 1.0).data());
      EXPECT_NEAR(lag, -1e-6 * 50.0 * 50.0 / (2.0 * 200.0) * 1e3,
                  1e-12);  // [Fujita thesis] eq. 2.1
    }
  }
  // Reversal spike: outward, height h right after the reversal in the direction of motion.
  ctx.direction = 1;
  const auto sp = Params(EffectId::kReversalSpikeU, 5.0);
  EXPECT_NEAR(RadialSignature(EffectId::kReversalSpikeU, ctx, 1e-9, sp.data()), 5.0, 1e-6);
  EXPECT_NEAR(RadialSignature(EffectId::kReversalSpikeU, ctx, std::numbers::pi + 1e-9, sp.data()),
              5.0, 1e-6);
  EXPECT_LT(std::abs(RadialSignature(EffectId::kReversalSpikeU, ctx, -0.01, sp.data())), 1e-3);
  ctx.direction = -1;
  EXPECT_NEAR(RadialSignature(EffectId::kReversalSpikeU, ctx, -1e-9, sp.data()), 5.0, 1e-6);
}

// The spike's radial signature is h·d(φ)·cos φ (φ the angle since the axis reversed, in
// degrees on the sample grid): outward right after every reversal of the axis, in both
// directions, and at a sample ON the reversal (to within the rounding of degrees → radians) its
// full height, whatever the sign of the velocity's rounding there.
TEST(EffectRegistry, ReversalSpikeIsOutwardAfterEveryReversal) {
  EffectContext ctx;
  for (int axis = 0; axis < 2; ++axis) {
    const EffectId id = axis == 0 ? EffectId::kReversalSpikeU : EffectId::kReversalSpikeV;
    for (double k : {1.0, 2.0}) {
      const std::vector<double> p = {3.5, 1.3, k};
      for (int s : {1, -1}) {
        ctx.direction = s;
        for (int i = -3600; i <= 3600; i += 7) {
          const double deg = 0.1 * i;
          double since = std::fmod(s * (deg - 90.0 * axis), 180.0);
          if (since < 0.0) since += 180.0;
          if (since > 180.0 - 1e-9) since = 0.0;
          const double d = k == 1.0 ? std::exp(-since / 1.3) : std::exp(-since * since / 3.38);
          const double expect = 3.5 * d * std::cos(since * std::numbers::pi / 180.0);
          EXPECT_NEAR(RadialSignature(id, ctx, deg * std::numbers::pi / 180.0, p.data()), expect,
                      1e-9)
              << "axis " << axis << " s " << s << " deg " << deg << " k " << k;
        }
        for (int r = -8; r <= 8; ++r) {
          if ((r + axis) % 2 != 0) continue;
          EXPECT_NEAR(RadialSignature(id, ctx, 90.0 * r * std::numbers::pi / 180.0, p.data()), 3.5,
                      1e-9)
              << "axis " << axis << " s " << s << " reversal at " << 90 * r << "°";
        }
      }
    }
  }
}

TEST(EffectRegistry, ServoMismatchMatchesExactAxisDelays) {
  // Independent forward model: each axis reproduces its command τ_a later, u(t) = u_cmd(t − τ_u),
  // v(t) = v_cmd(t − τ_v), on a circle run at ω = V / R in direction s. The radial error of the
  // exact delayed point, minus the second-order radius loss, must equal the registry signature
  // for Δτ = τ_u − τ_v (first axis minus second, docs/formats.md §4) to first order in ωτ.
  EffectContext ctx;
  ctx.radius_mm = 100.0;
  ctx.feed_mm_min = 6000.0;               // V = 100 mm/s, ω = 1 rad/s
  const double tu = 2.0e-3, tv = 0.5e-3;  // s
  const double r_um = ctx.radius_mm * 1000.0;
  const double w = ctx.SpeedMmPerS() / ctx.radius_mm;
  for (int s : {1, -1}) {
    ctx.direction = s;
    const std::vector<double> p = {(tu - tv) * 1e3};  // ms
    for (double th = 0.1; th < 6.28; th += 0.5) {
      const double u = r_um * std::cos(th - s * w * tu);
      const double v = r_um * std::sin(th - s * w * tv);
      const double exact = u * std::cos(th) + v * std::sin(th) - r_um;
      // Second-order radius loss of each axis (even in s, not part of the mismatch signature):
      // R [cos²θ (cos ωτ_u − 1) + sin²θ (cos ωτ_v − 1)].
      const double loss = r_um * (std::pow(std::cos(th), 2) * (std::cos(w * tu) - 1.0) +
                                  std::pow(std::sin(th), 2) * (std::cos(w * tv) - 1.0));
      EXPECT_NEAR(RadialSignature(EffectId::kServoMismatch, ctx, th, p.data()), exact - loss,
                  1e-3 * std::abs(exact) + 1e-9);
    }
  }
}

TEST(EffectRegistry, SquarenessSignMeansObtuseAngle) {
  // Positive squareness: the machine's +v direction leans towards −u, so the angle between the
  // images of +u and +v exceeds 90°.
  EffectContext ctx;
  const auto p = Params(EffectId::kSquareness, 100.0);
  double eu[2], ev[2];
  PositionError(EffectId::kSquareness, ctx, 0.0, p.data(), eu);
  PositionError(EffectId::kSquareness, ctx, std::numbers::pi / 2.0, p.data(), ev);
  const double r = ctx.radius_mm * 1000.0;
  const double ux = r + eu[0], uy = eu[1], vx = ev[0], vy = r + ev[1];
  const double angle = std::acos((ux * vx + uy * vy) / (std::hypot(ux, uy) * std::hypot(vx, vy)));
  EXPECT_GT(angle, std::numbers::pi / 2.0);
  EXPECT_NEAR(angle - std::numbers::pi / 2.0, 100e-6, 1e-9);
}

// The distance to the nearest quarter turn without a call to round: the same decision as
// |q − round(q)| on samples at, near and between the reversals, on ties (q + ½), beyond 2⁵²
// quarter turns and on values that are not numbers.
TEST(EffectRegistry, AtAxisReversalIsTheRoundedDistance) {
  constexpr double kQuarter = std::numbers::pi / 2.0;
  const auto by_round = [&](double theta) {
    const double q = theta / kQuarter;
    return std::abs(q - std::round(q)) * kQuarter < internal::kAtReversalRad;
  };
  std::vector<double> thetas = {0.0,
                                -0.0,
                                1e-300,
                                5e-7,
                                7e-7,
                                -7e-7,
                                0.5 * kQuarter,
                                1.5 * kQuarter,
                                -2.5 * kQuarter,
                                1e20,
                                -1e20,
                                std::numeric_limits<double>::infinity(),
                                std::numeric_limits<double>::quiet_NaN()};
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> turn(-20.0, 20.0), off(-2e-6, 2e-6);
  for (int i = 0; i < 20000; ++i) {
    const double k = std::round(turn(rng));
    thetas.push_back(k * kQuarter + off(rng));  // near a reversal
    thetas.push_back(turn(rng));                // anywhere
    thetas.push_back((k + 0.5) * kQuarter);     // half-way between two
  }
  int near = 0;
  for (double th : thetas) {
    ASSERT_EQ(internal::AtAxisReversal(th), by_round(th)) << th;
    near += by_round(th) ? 1 : 0;
  }
  EXPECT_GT(near, 5000);  // both answers were exercised
  EXPECT_LT(near, 20000);
}

}  // namespace
}  // namespace km::serial_effects
