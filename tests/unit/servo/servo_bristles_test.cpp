// The bristle force's derivatives (analysis/servo/feed_drive_bristles.cpp), carried through the
// exact steps of eq. 4.1, against central differences of the force itself in each parameter:
// for the Gaussian rise, a fitted exponent δ and the Lorentzian rise, with the speed read
// linear between samples and constant, over a reversal with a standstill in it. A first-principle
// check that needs no simulator: stiffer bristles (a larger σ0) carry the friction over to the
// new direction of motion in a shorter travel.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/servo/feed_drive_detail.h"

namespace km::servo::detail {
namespace {

// A reversal at 2 ms sampling: x = −A cos(ω τ), moving in −x at 2.4 mm/s and slowing to the
// turning point (sample 200), 10 samples at rest there, then moving back in +x; the speeds by
// the exact derivative.
Strokes Reversal() {
  Strokes s;
  const double a = 0.8, w = M_PI, dt = 2e-3;
  for (int i = 0; i < 400; ++i) {
    const double tau = (i < 200 ? i - 200 : (i < 210 ? 0 : i - 210)) * dt;
    s.t.push_back(i * dt);
    s.x.push_back(-a * std::cos(w * tau));
    s.v.push_back(a * w * std::sin(w * tau));
  }
  s.segment_end = {s.x.size()};
  return s;
}

LugreParameters Params(LugreParameters::Form form, double delta) {
  LugreParameters p;
  p.Fc_N = 30.0;
  p.Fs_N = 37.3;
  p.vs_mm_s = 1.9;
  p.sigma0_N_per_um = 4.4;
  p.sigma1_N_s_per_mm = 7.7;
  p.sigma2_N_s_per_mm = 0.05;
  p.stribeck_exponent = delta;
  p.stribeck_form = form;
  return p;
}

// p with parameter k (ln F_s, ln v_s, ln σ0, ln δ) moved by h.
LugreParameters Moved(LugreParameters p, int k, double h) {
  double* value[] = {&p.Fs_N, &p.vs_mm_s, &p.sigma0_N_per_um, &p.stribeck_exponent};
  *value[k] *= std::exp(h);
  return p;
}

void ExpectDerivativesMatchDifferences(const LugreParameters& p, Reading reading, int params) {
  const Strokes s = Reversal();
  const std::vector<Window> ws{{0, 399}};
  std::vector<double> force, damping;
  std::vector<BristleDerivatives> d;
  BristleForce(s, ws, p, reading, force, &damping, &d, params == 4);
  std::vector<double> plain;
  BristleForce(s, ws, p, reading, plain);
  ASSERT_EQ(plain, force);  // the same arithmetic with and without the derivatives
  ASSERT_EQ(d.size(), force.size());
  const double h = 1e-5;
  for (int k = 0; k < params; ++k) {
    std::vector<double> up, down;
    BristleForce(s, ws, Moved(p, k, h), reading, up);
    BristleForce(s, ws, Moved(p, k, -h), reading, down);
    double worst = 0.0, scale = 0.0;
    for (std::size_t i = 0; i < force.size(); ++i) {
      const double fd = (up[i] - down[i]) / (2.0 * h);
      worst = std::max(worst, std::abs(d[i][k] - fd));
      scale = std::max(scale, std::abs(fd));
    }
    EXPECT_GT(scale, 1e-3) << "parameter " << k << " moves the force";
    EXPECT_LT(worst, 1e-6 * scale + 1e-9) << "parameter " << k;
  }
  // σ1 enters linearly through 10⁻³ dz/dt.
  LugreParameters q = p;
  q.sigma1_N_s_per_mm += 1.0;
  std::vector<double> more;
  BristleForce(s, ws, q, reading, more);
  for (std::size_t i = 0; i < force.size(); ++i)
    EXPECT_NEAR(more[i] - force[i], damping[i], 1e-9 * (1.0 + std::abs(force[i])));
}

// The four-lane path (where the processor has AVX2) gives the force, the damping and the
// derivatives bit for bit as the two-lane one: for the rises it covers (Gaussian, Lorentzian)
// and those it leaves to the other (a fitted exponent), both readings, and bristles so stiff
// that the decay over a step underflows (exp of −709 and beyond, subnormal and zero results).
TEST(ServoBristles, FourLanePathIsBitForBitTheTwoLaneOne) {
  const Strokes s = Reversal();
  const std::vector<Window> ws{{0, 399}};
  struct Case {
    LugreParameters p;
    bool exponent;
  };
  std::vector<Case> cases;
  for (auto form : {LugreParameters::Form::kExponential, LugreParameters::Form::kLorentzian}) {
    for (double sigma0 : {4.4, 3e4, 9e6}) {
      LugreParameters p = Params(form, 2.0);
      p.sigma0_N_per_um = sigma0;
      cases.push_back({p, false});
      cases.push_back({p, true});
    }
  }
  // A fitted exponent (the logarithm of the speed ratio), also at the ends of its range and
  // with Stribeck speeds that send the ratio to the clamp of 10⁻³⁰⁰ or the power to infinity.
  for (double delta : {1.37, 0.5, 6.0}) {
    for (double vs : {1.9, 1e-200, 1e250}) {
      LugreParameters p = Params(LugreParameters::Form::kExponential, delta);
      p.vs_mm_s = vs;
      cases.push_back({p, true});
      cases.push_back({p, false});
    }
  }
  for (const auto& c : cases) {
    for (Reading reading : {Reading::kLinear, Reading::kConstant}) {
      std::array<std::vector<double>, 2> force, damping;
      std::array<std::vector<BristleDerivatives>, 2> d;
      for (int lanes = 0; lanes < 2; ++lanes) {
        UseFeedDriveAvx2(lanes == 1);
        BristleForce(s, ws, c.p, reading, force[lanes], &damping[lanes], &d[lanes], c.exponent);
      }
      UseFeedDriveAvx2(true);
      const auto bits = [](const std::vector<double>& v) {
        std::vector<std::uint64_t> out(v.size());
        std::memcpy(out.data(), v.data(), v.size() * sizeof(double));
        return out;
      };
      EXPECT_EQ(bits(force[0]), bits(force[1])) << c.p.sigma0_N_per_um;
      EXPECT_EQ(bits(damping[0]), bits(damping[1])) << c.p.sigma0_N_per_um;
      ASSERT_EQ(d[0].size(), d[1].size());
      for (std::size_t i = 0; i < d[0].size(); ++i) {
        for (int k = 0; k < kBristleParams; ++k) {
          std::uint64_t a = 0, b = 0;
          std::memcpy(&a, &d[0][i][k], sizeof a);
          std::memcpy(&b, &d[1][i][k], sizeof b);
          ASSERT_EQ(a, b) << "sample " << i << " parameter " << k << " σ0 " << c.p.sigma0_N_per_um;
        }
      }
    }
  }
}

TEST(ServoBristles, DerivativesOfTheGaussianRise) {
  ExpectDerivativesMatchDifferences(Params(LugreParameters::Form::kExponential, 2.0),
                                    Reading::kLinear, 3);
  ExpectDerivativesMatchDifferences(Params(LugreParameters::Form::kExponential, 2.0),
                                    Reading::kConstant, 3);
}

TEST(ServoBristles, DerivativesWithTheExponentFitted) {
  ExpectDerivativesMatchDifferences(Params(LugreParameters::Form::kExponential, 1.37),
                                    Reading::kLinear, 4);
  ExpectDerivativesMatchDifferences(Params(LugreParameters::Form::kExponential, 3.1),
                                    Reading::kConstant, 4);
}

TEST(ServoBristles, DerivativesOfTheLorentzianRise) {
  ExpectDerivativesMatchDifferences(Params(LugreParameters::Form::kLorentzian, 2.0),
                                    Reading::kLinear, 2);  // δ unused; σ0 below
  const Strokes s = Reversal();
  std::vector<double> force;
  std::vector<BristleDerivatives> d;
  BristleForce(s, {{0, 399}}, Params(LugreParameters::Form::kLorentzian, 2.0), Reading::kLinear,
               force, nullptr, &d, false);
  for (const auto& x : d) EXPECT_EQ(x[3], 0.0);  // no exponent: no derivative in it
}

TEST(ServoBristles, StifferBristlesTurnTheForceInAShorterTravel) {
  const Strokes s = Reversal();
  const std::vector<Window> ws{{0, 399}};
  std::vector<double> soft, stiff;
  LugreParameters p = Params(LugreParameters::Form::kExponential, 2.0);
  BristleForce(s, ws, p, Reading::kLinear, soft);
  p.sigma0_N_per_um *= 2.0;
  BristleForce(s, ws, p, Reading::kLinear, stiff);
  // At rest the bristles hold the force of the old direction (−x): about −F_s either way.
  EXPECT_NEAR(soft[205], -p.Fs_N, 1.0);
  EXPECT_NEAR(stiff[205], -p.Fs_N, 1.0);
  // 20 samples (6 µm) into the new direction the stiffer bristles push harder in +x.
  EXPECT_GT(stiff[230], soft[230] + 5.0);
  // Sliding again, both carry the friction of the new direction.
  EXPECT_GT(soft[399], 0.9 * p.Fc_N);
  EXPECT_GT(stiff[399], 0.9 * p.Fc_N);
}

// FindPeriods on binned ripple of two sinusoids (periods 37.3 and 11.9 mm, off any grid of
// the search) plus a constant, with gaps in the bins (where the phase is taken afresh): both
// periods and amplitudes recovered, and the four-lane periodogram bit for bit the one-lane one.
TEST(ServoPeriods, FindsBothRipplesAndTheFourLanePathIsBitForBit) {
  std::vector<double> xc, y;
  for (int b = 0; b < 480; ++b) {
    if (b % 97 == 50 || b % 131 == 7) continue;  // empty bins
    const double x = -60.0 + 0.5 * (b + 0.5);
    xc.push_back(x);
    y.push_back(0.7 + 2.5 * std::cos(2.0 * M_PI * x / 37.3 + 0.4) +
                1.1 * std::sin(2.0 * M_PI * x / 11.9 - 1.3));
  }
  std::array<std::vector<RippleComponent>, 2> found;
  for (int lanes = 0; lanes < 2; ++lanes) {
    UseFeedDriveAvx2(lanes == 1);
    found[lanes] = FindPeriods(xc, y, 2.0, 120.0, 3);
  }
  UseFeedDriveAvx2(true);
  // One sinusoid at a time (the joint fit refines them together): each estimate carries the
  // other's leakage over the 240 mm, here 0.015 mm and 0.017 N for the first.
  ASSERT_GE(found[0].size(), 2u);
  EXPECT_NEAR(found[0][0].period, 37.3, 0.04);
  EXPECT_NEAR(std::hypot(found[0][0].a, found[0][0].b), 2.5, 0.04);
  EXPECT_NEAR(found[0][1].period, 11.9, 1e-3);
  EXPECT_NEAR(std::hypot(found[0][1].a, found[0][1].b), 1.1, 5e-3);
  ASSERT_EQ(found[0].size(), found[1].size());
  for (std::size_t k = 0; k < found[0].size(); ++k) {
    EXPECT_EQ(found[0][k].period, found[1][k].period) << k;
    EXPECT_EQ(found[0][k].a, found[1][k].a) << k;
    EXPECT_EQ(found[0][k].b, found[1][k].b) << k;
  }
  // The periodogram itself: the four-lane one bit for bit, and both against the least squares
  // of a sinusoid with a constant solved in long double from sines and cosines of each bin.
  std::vector<double> periods;
  for (int k = 0; k < 203; ++k) periods.push_back(2.0 * std::pow(60.0, k / 202.0));
  std::array<std::vector<double>, 2> rss;
  for (int lanes = 0; lanes < 2; ++lanes) {
    UseFeedDriveAvx2(lanes == 1);
    rss[lanes] = PeriodogramOf(xc, y, periods);
  }
  UseFeedDriveAvx2(true);
  double yy = 0.0;
  for (double v : y) yy += v * v;
  for (std::size_t k = 0; k < periods.size(); ++k) {
    EXPECT_EQ(rss[0][k], rss[1][k]) << "period " << periods[k];
    long double m[3][4] = {};
    for (std::size_t i = 0; i < xc.size(); ++i) {
      const long double w = 2.0L * std::numbers::pi_v<long double> * xc[i] / periods[k];
      const long double row[4] = {1.0L, std::cos(w), std::sin(w), y[i]};
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) m[r][c] += row[r] * row[c];
    }
    for (int r = 0; r < 3; ++r) {  // Gauss–Jordan on the 3 × 3 normal equations
      for (int q = 0; q < 3; ++q) {
        if (q == r) continue;
        const long double f = m[q][r] / m[r][r];
        for (int c = 0; c < 4; ++c) m[q][c] -= f * m[r][c];
      }
    }
    long double fitted = 0.0L;
    for (int r = 0; r < 3; ++r)
      fitted += m[r][3] / m[r][r] * [&] {
        long double s = 0.0L;
        for (std::size_t i = 0; i < xc.size(); ++i) {
          const long double w = 2.0L * std::numbers::pi_v<long double> * xc[i] / periods[k];
          const long double col[3] = {1.0L, std::cos(w), std::sin(w)};
          s += col[r] * y[i];
        }
        return s;
      }();
    EXPECT_NEAR(rss[0][k], static_cast<double>(yy - fitted), 1e-9 * yy) << periods[k];
  }
}

}  // namespace
}  // namespace km::servo::detail
