// The vectorised spike decays of the width search (analysis/dbb/spike_decay.h) are bit for bit
// the Eigen array expressions they replace, for every length (the four-lane part, the last pair
// and an odd last element) and both decay shapes, over the whole range the search evaluates.
#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>

#include "analysis/dbb/signatures.h"
#include "analysis/dbb/spike_decay.h"
#include "analysis/serial_effects/registry.h"

namespace km::dbb::diag {
namespace {

// Every length (the four-lane part and each tail) and both shapes, over the reach of the search
// (e⁻⁷) and of the signatures (e⁻⁴⁰): within three ulps of the decay by std::exp.
TEST(SpikeDecay, WithinUlpsOfTheExponential) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const bool gaussian : {false, true}) {
    for (Eigen::Index n = 0; n <= 41; ++n) {
      const double w = 0.001 + 0.2 * unit(rng);
      const double reach = gaussian ? std::sqrt(80.0) * w : 40.0 * w;
      Eigen::ArrayXd phi(n), factor(n);
      for (Eigen::Index k = 0; k < n; ++k) {
        phi[k] = reach * unit(rng) * (k % 2 == 0 ? 1.0 : 7.0 / 40.0);
        factor[k] = 2.0 * unit(rng) - 1.0;
      }
      if (n > 0) phi[0] = 0.0;
      Eigen::VectorXd got(n);
      SpikeDecays(phi.data(), factor.data(), n, w, gaussian, got.data());
      for (Eigen::Index k = 0; k < n; ++k) {
        const double x = phi[k] / w;
        const double want = factor[k] * std::exp(gaussian ? -0.5 * x * x : -x);
        // The argument's own rounding (φ·(1/w) against φ/w: 1.5 ulps, 3 once squared) moves the
        // decay by that many ulps times the argument (up to 40).
        const double arg_ulps = 1.0 + (gaussian ? 3.0 * 0.5 * x * x : 1.5 * x);
        EXPECT_LE(std::abs(got[k] - want), (3.0 + arg_ulps) * 2.3e-16 * std::abs(want))
            << "n " << n << " k " << k << " gaussian " << gaussian;
      }
    }
  }
}

TEST(SpikeDecay, DecaysAsTheModel) {
  const Eigen::ArrayXd phi = Eigen::ArrayXd::LinSpaced(9, 0.0, 0.08);
  const Eigen::ArrayXd factor = Eigen::ArrayXd::Constant(9, -2.0);
  Eigen::VectorXd e(9), g(9);
  SpikeDecays(phi.data(), factor.data(), 9, 0.02, false, e.data());
  SpikeDecays(phi.data(), factor.data(), 9, 0.02, true, g.data());
  for (Eigen::Index k = 0; k < 9; ++k) {
    const double x = phi[k] / 0.02;
    EXPECT_NEAR(e[k], -2.0 * std::exp(-x), 1e-15);
    EXPECT_NEAR(g[k], -2.0 * std::exp(-0.5 * x * x), 1e-15);
  }
}

// The set-up-free signature of a reversal spike, whose decays are taken four at a time
// (signatures.cpp), against the registry model evaluated sample by sample (std::exp) with the
// same set-up removal: within rounding for both axes, both directions, narrow to wide spikes and
// both decay shapes; an exponent of 1.5 takes the model's own path.
TEST(SpikeDecay, SpikeSignatureIsTheModelsSampleBySample) {
  std::vector<DiagnosisTrace> traces(2);
  for (std::size_t t = 0; t < 2; ++t) {
    traces[t].direction = t == 0 ? Direction::kCcw : Direction::kCw;
    traces[t].radius_mm = 150.0;
    for (int i = 0; i < 3600; ++i) {
      const double deg = (t == 0 ? 0.1 : -0.1) * i + 0.037;
      traces[t].angle_rad.push_back(deg * std::numbers::pi / 180.0);
      traces[t].dev_um.push_back(0.0);
    }
  }
  const StackedTraces p = StackTraces(traces, true);
  using serial_effects::EffectId;
  for (const EffectId id : {EffectId::kReversalSpikeU, EffectId::kReversalSpikeV}) {
    for (const double w : {0.05, 0.73, 2.3, 7.9}) {
      for (const double k : {1.0, 2.0, 1.5}) {
        const EffectColumns c = SetupFreeSignature(p, id, {w, k});
        Eigen::VectorXd ref(p.n);
        const double params[3] = {1.0, w, k};
        for (int i = 0; i < p.n; ++i) {
          const auto& s = p.samples[static_cast<std::size_t>(i)];
          ref[i] = serial_effects::RadialSignature(id, p.ctx[static_cast<std::size_t>(s.trace)],
                                                   s.a, params);
        }
        const double scale = ref.cwiseAbs().maxCoeff();
        ASSERT_GT(scale, 0.1);
        p.RemoveSetup(ref);
        EXPECT_LT((c.cols[0] - ref).cwiseAbs().maxCoeff(), 1e-14 * scale)
            << "width " << w << " exponent " << k;
      }
    }
  }
}

// Each axis' reversal phase of every sample, computed four at a time (reversal_phases.cpp), is
// bit for bit the model's: both directions, angles beyond a turn, samples at, just before and
// just after the reversals (within and beyond kAtReversalRad) and exactly on multiples of π/2.
TEST(SpikeDecay, ReversalPhasesAreTheModelsBitForBit) {
  std::vector<DiagnosisTrace> traces(2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> near(-3e-6, 3e-6);
  for (std::size_t t = 0; t < 2; ++t) {
    traces[t].direction = t == 0 ? Direction::kCcw : Direction::kCw;
    traces[t].radius_mm = 100.0;
    for (int i = 0; i < 2003; ++i) {
      double th = (t == 0 ? 1.0 : -1.0) * (0.0031 * i - 0.5);
      if (i % 7 == 0) th = std::round(th / (std::numbers::pi / 2)) * (std::numbers::pi / 2);
      if (i % 11 == 0) th += near(rng);
      traces[t].angle_rad.push_back(th);
      traces[t].dev_um.push_back(0.0);
    }
  }
  StackedTraces p = StackTraces(traces);
  p.ComputeReversalPhases();
  for (int i = 0; i < p.n; ++i) {
    const auto& s = p.samples[static_cast<std::size_t>(i)];
    const auto& c = p.ctx[static_cast<std::size_t>(s.trace)];
    const auto u = serial_effects::ReversalSpike<0>::Phase(c, s.a);
    const auto v = serial_effects::ReversalSpike<1>::Phase(c, s.a);
    const auto k = static_cast<std::size_t>(i);
    ASSERT_EQ(std::memcmp(&p.reversal_phase[0].phi[k], &u.phi, sizeof(double)), 0) << i;
    ASSERT_EQ(p.reversal_phase[0].side[k], u.side) << i;
    ASSERT_EQ(std::memcmp(&p.reversal_phase[1].phi[k], &v.phi, sizeof(double)), 0) << i;
    ASSERT_EQ(p.reversal_phase[1].side[k], v.side) << i;
  }
}

}  // namespace
}  // namespace km::dbb::diag
