// Reversal spikes and stick-slip recovered from an independent truth simulator (dbb_truth.h):
// the spike's decay constant (exponential) or width (Gaussian-like) is a fitted parameter with
// its uncertainty, the height comes out right whatever the width; stick_slip is a fitted
// signature named only on the evidence of its own sawtooth.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/diagnosis.h"
#include "analysis/dbb/iso230.h"
#include "tests/unit/dbb/dbb_test_util.h"
#include "tests/unit/dbb/dbb_truth.h"

namespace km::dbb {
namespace {

using test::Describe;
using test::Named;
using truth::Effect;
using truth::Kind;

truth::Setup Machine(unsigned seed, double noise, std::vector<Effect> effects) {
  truth::Setup st;
  st.seed = seed;
  st.noise_um = noise;
  st.fixed_ball_err_um = {3.0, -2.0};
  st.effects = std::move(effects);
  return st;
}

// Exponential decay of 0.95°, between the old fixed widths 0.5° and 1°: 5.0 µm ± 0.2 µm
// (3.9 µm before the width was fitted), decay constant within 10 %.
TEST(ReversalSpike, ExponentialDecayIsFittedWithItsUncertainty) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const auto r =
        test::DiagnoseTests(truth::Pair(Machine(seed, 0.3, {{Kind::kSpikeExp, 1, {5.0, 0.95}}})));
    const auto* e = Named(r, "reversal_spike_y");
    ASSERT_NE(e, nullptr) << Describe(r);
    EXPECT_NEAR(e->value[0], 5.0, 0.2) << Describe(r);
    EXPECT_EQ(e->shape_kind, "exponential") << Describe(r);
    ASSERT_TRUE(e->shape.count("width_deg")) << Describe(r);
    ASSERT_TRUE(e->shape_uncertainty.count("width_deg")) << Describe(r);
    const double w = e->shape.at("width_deg"), uw = e->shape_uncertainty.at("width_deg");
    EXPECT_NEAR(w, 0.95, 0.095) << Describe(r);
    EXPECT_GT(uw, 0.0);
    EXPECT_LT(std::abs(w - 0.95), 4.0 * uw + 0.01) << Describe(r);
    EXPECT_EQ(Named(r, "stick_slip"), nullptr) << Describe(r);
  }
}

// Same spike (4 µm) beside a scale mismatch of 30 ppm: 4.0 µm ± 0.2 µm (2.8 µm before), the
// scale mismatch within 5 %, and no stick_slip.
TEST(ReversalSpike, BesideAScaleMismatch) {
  for (unsigned seed : {4u, 5u, 6u}) {
    const auto r = test::DiagnoseTests(truth::Pair(Machine(
        seed, 0.3, {{Kind::kScaleMismatch, 0, {30.0}}, {Kind::kSpikeExp, 0, {4.0, 0.95}}})));
    const auto* e = Named(r, "reversal_spike_x");
    const auto* sc = Named(r, "scale_mismatch");
    ASSERT_TRUE(e && sc) << Describe(r);
    EXPECT_NEAR(e->value[0], 4.0, 0.2) << Describe(r);
    EXPECT_NEAR(e->shape.at("width_deg"), 0.95, 0.095) << Describe(r);
    EXPECT_NEAR(sc->value[0], 30.0, 1.5) << Describe(r);
    EXPECT_EQ(Named(r, "stick_slip"), nullptr) << Describe(r);
  }
}

// Gaussian-like spike exp(−φ²/2w²) of width 1.5°: recognised as such, height within 0.2 µm,
// width within 10 %.
TEST(ReversalSpike, GaussianLikeShapeIsRecognised) {
  for (unsigned seed : {7u, 8u, 9u}) {
    const auto r =
        test::DiagnoseTests(truth::Pair(Machine(seed, 0.3, {{Kind::kSpikeGauss, 0, {4.0, 1.5}}})));
    const auto* e = Named(r, "reversal_spike_x");
    ASSERT_NE(e, nullptr) << Describe(r);
    EXPECT_NEAR(e->value[0], 4.0, 0.2) << Describe(r);
    EXPECT_EQ(e->shape_kind, "gaussian") << Describe(r);
    EXPECT_NEAR(e->shape.at("width_deg"), 1.5, 0.15) << Describe(r);
    EXPECT_EQ(Named(r, "stick_slip"), nullptr) << Describe(r);
  }
}

// Wide and narrow decays across the range: 0.4° … 3.3°, both axes at once.
TEST(ReversalSpike, BothAxesAtDifferentDecays) {
  for (unsigned seed : {10u, 11u}) {
    const auto r = test::DiagnoseTests(truth::Pair(
        Machine(seed, 0.2, {{Kind::kSpikeExp, 0, {3.0, 0.4}}, {Kind::kSpikeExp, 1, {6.0, 3.3}}})));
    const auto* x = Named(r, "reversal_spike_x");
    const auto* y = Named(r, "reversal_spike_y");
    ASSERT_TRUE(x && y) << Describe(r);
    EXPECT_NEAR(x->value[0], 3.0, 0.2) << Describe(r);
    EXPECT_NEAR(y->value[0], 6.0, 0.2) << Describe(r);
    EXPECT_NEAR(x->shape.at("width_deg"), 0.4, 0.04) << Describe(r);
    EXPECT_NEAR(y->shape.at("width_deg"), 3.3, 0.33) << Describe(r);
  }
}

// Coarse sampling (one trace, 1° steps, noise 0.15 µm): the spike is only a few samples wide
// (decay 2.6°), the decay shape is uncertain, yet the height is unbiased — the mean of 12 noise
// realisations within 0.25 µm of 5.0 µm and every value within 3.5 reported uncertainties. (A
// decay of 0.95° at 1° steps is narrower than the samples resolve once the samples at the
// reversals are left out: spike_shape_test.cpp. With noise 0.5 µm this spike is about 1 µm
// uncertain beside the other effects of the axis on one trace, and not always named.)
TEST(ReversalSpike, CoarseSingleTraceIsUnbiased) {
  double sum = 0.0;
  const int n = 12;
  for (int seed = 1; seed <= n; ++seed) {
    auto st = Machine(static_cast<unsigned>(seed), 0.15, {{Kind::kSpikeExp, 1, {5.0, 2.6}}});
    const auto r = test::DiagnoseTests(
        {truth::Simulate(st, truth::Angles(Direction::kCcw, 0.0, 360.0, 1.0, true))});
    const auto* e = Named(r, "reversal_spike_y");
    ASSERT_NE(e, nullptr) << Describe(r);
    EXPECT_LT(std::abs(e->value[0] - 5.0), 3.5 * e->uncertainty[0]) << Describe(r);
    sum += e->value[0];
  }
  EXPECT_NEAR(sum / n, 5.0, 0.25);
}

// The width uncertainty agrees with the scatter over noise realisations (12 seeds; a sample
// standard deviation of 12 values is within ±50 % of σ with high probability).
TEST(ReversalSpike, WidthUncertaintyMatchesScatter) {
  std::vector<double> w, h;
  double uw = 0.0, uh = 0.0;
  const int n = 12;
  for (int seed = 0; seed < n; ++seed) {
    const auto r = test::DiagnoseTests(truth::Pair(
        Machine(200u + static_cast<unsigned>(seed), 0.5, {{Kind::kSpikeExp, 1, {3.0, 1.2}}})));
    const auto* e = Named(r, "reversal_spike_y");
    ASSERT_NE(e, nullptr) << Describe(r);
    w.push_back(e->shape.at("width_deg"));
    h.push_back(e->value[0]);
    uw += e->shape_uncertainty.at("width_deg") / n;
    uh += e->uncertainty[0] / n;
  }
  auto sd = [&](const std::vector<double>& v) {
    double m = 0.0, s = 0.0;
    for (double x : v) m += x / n;
    for (double x : v) s += (x - m) * (x - m) / (n - 1);
    return std::sqrt(s);
  };
  EXPECT_NEAR(sd(w), uw, 0.5 * uw);
  EXPECT_NEAR(sd(h), uh, 0.5 * uh);
}

// stick_slip is not named beside effects that leave structure near the reversals: backlash with
// a cyclic error, a scale mismatch with a spike, a backlash taken up softly (a shape no model
// has).
TEST(StickSlip, NotNamedBesideOtherReversalEffects) {
  const std::vector<std::vector<Effect>> machines = {
      {{Kind::kBacklash, 0, {3.0}}, {Kind::kCyclic, 1, {1.0, 0.5, 8.0}}},
      {{Kind::kScaleMismatch, 0, {25.0}}, {Kind::kSpikeExp, 1, {5.0, 0.95}}},
      {{Kind::kSoftBacklash, 0, {4.0, 1.0}}},
      {{Kind::kBacklash, 1, {2.0}}, {Kind::kSpikeGauss, 0, {3.0, 0.7}}},
  };
  for (std::size_t m = 0; m < machines.size(); ++m) {
    for (unsigned seed : {21u, 22u, 23u}) {
      const auto r = test::DiagnoseTests(truth::Pair(Machine(seed, 0.3, machines[m])));
      EXPECT_EQ(Named(r, "stick_slip"), nullptr) << "machine " << m << ": " << Describe(r);
    }
  }
}

// Stick-slip (sawtooth of amplitude 0.6 µm in the low-speed zones) is named with its amplitude
// within 10 % and its period within 1 %, also beside a spike and a backlash; the spike keeps
// its height (± 0.2 µm). Periods 0.73° (teeth between the 0.1° samples) and 0.5° (every fifth
// sample on a jump, where the truth's rounding picks the side of the jump).
TEST(StickSlip, FittedWhenPresent) {
  for (double period : {0.73, 0.5}) {
    for (unsigned seed : {31u, 32u, 33u}) {
      const auto r = test::DiagnoseTests(truth::Pair(Machine(seed, 0.2,
                                                             {{Kind::kStickSlip, 0, {0.6, period}},
                                                              {Kind::kBacklash, 0, {2.0}},
                                                              {Kind::kSpikeExp, 1, {3.0, 1.0}}})));
      const auto* s = Named(r, "stick_slip");
      ASSERT_NE(s, nullptr) << Describe(r);
      EXPECT_NEAR(s->value[0], 0.6, 0.06) << period << ": " << Describe(r);
      EXPECT_NEAR(s->shape.at("period_deg"), period, 0.01 * period) << Describe(r);
      EXPECT_GT(s->significance, 4.0);
      const auto* sp = Named(r, "reversal_spike_y");
      ASSERT_NE(sp, nullptr) << Describe(r);
      EXPECT_NEAR(sp->value[0], 3.0, 0.2) << period << ": " << Describe(r);
      const auto* bl = Named(r, "backlash_x");
      ASSERT_NE(bl, nullptr) << Describe(r);
      EXPECT_NEAR(bl->value[0], 2.0, 0.1) << period << ": " << Describe(r);
    }
  }
}

// Noise alone: neither spikes nor stick-slip (the width and period searches do not make a
// feature out of noise), 10 seeds of a pair and 5 of a single trace at 0.5° (where stick_slip
// is listed as not assessed).
TEST(StickSlip, NoiseAloneNamesNoSpikeNorStickSlip) {
  auto check = [](const DiagnosisResult& r, unsigned seed) {
    for (const auto& e : r.named) {
      EXPECT_TRUE(e.effect.rfind("reversal_spike", 0) != 0 && e.effect != "stick_slip")
          << "seed " << seed << ": " << Describe(r);
    }
  };
  for (unsigned seed = 40; seed < 50; ++seed)
    check(test::DiagnoseTests(truth::Pair(Machine(seed, 0.3, {}))), seed);
  for (unsigned seed = 50; seed < 55; ++seed) {
    auto st = Machine(seed, 0.3, {});
    const auto r = test::DiagnoseTests(
        {truth::Simulate(st, truth::Angles(Direction::kCcw, 0.0, 360.0, 0.5, true))});
    check(r, seed);
    // At 0.5° steps the sawtooth's teeth are not resolved: not assessed, and said so.
    bool listed = false;
    for (const auto& n : r.not_identifiable)
      listed |= n.rfind("stick_slip (samples too far", 0) == 0;
    EXPECT_TRUE(listed) << Describe(r);
  }
}

}  // namespace
}  // namespace km::dbb
