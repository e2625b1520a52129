// Harmonics: recover injected amplitudes and phases from uniform and non-uniform sampling;
// compare with the DFT for uniform sampling.
#include "analysis/dbb/harmonics.h"

#include <cmath>
#include <complex>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Dense>

namespace km::dbb {
namespace {

TEST(Harmonics, RecoversAmplitudeAndPhaseNonUniform) {
  for (unsigned seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> g(0.0, 0.05);
    const double amp[4] = {0.0, 2.0 * u(rng), 1.0 + u(rng), 0.5 * u(rng)};  // orders 1..3
    const double ph[4] = {0.0, 360.0 * u(rng), 360.0 * u(rng), 360.0 * u(rng)};
    std::vector<double> a, r;
    for (int i = 0; i < 2000; ++i) {
      const double t = 2.0 * std::numbers::pi * (i + 0.45 * (u(rng) - 0.5)) / 2000.0 + 0.3;
      double v = 0.7 + g(rng);
      for (int k = 1; k <= 3; ++k) v += amp[k] * std::cos(k * t - ph[k] * std::numbers::pi / 180.0);
      a.push_back(t);
      r.push_back(v);
    }
    const auto h = FitHarmonics(a, r, 8);
    ASSERT_EQ(h.harmonics.size(), 8u);
    EXPECT_NEAR(h.mean_um, 0.7, 0.01);
    for (int k = 1; k <= 3; ++k) {
      EXPECT_NEAR(h.harmonics[k - 1].amplitude_um, amp[k], 0.01) << "order " << k;
      double dphi = std::remainder(h.harmonics[k - 1].phase_deg - ph[k], 360.0);
      if (amp[k] > 0.1) {
        EXPECT_NEAR(dphi, 0.0, 0.01 / amp[k] * 180.0 / std::numbers::pi * 3.0);
      }
    }
    for (int k = 4; k <= 8; ++k) EXPECT_LT(h.harmonics[k - 1].amplitude_um, 0.01);
    EXPECT_NEAR(h.residual_rms_um, 0.05, 0.005);
  }
}

TEST(Harmonics, UniformSamplingAgreesWithDft) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 360;
  std::vector<double> a(n), r(n);
  for (int i = 0; i < n; ++i) {
    a[i] = 2.0 * std::numbers::pi * i / n;
    r[i] = g(rng);
  }
  const auto h = FitHarmonics(a, r, 5);
  for (int k = 1; k <= 5; ++k) {
    std::complex<double> s = 0.0;
    for (int i = 0; i < n; ++i) s += r[i] * std::exp(std::complex<double>(0.0, -k * a[i]));
    const std::complex<double> ck = 2.0 * s / static_cast<double>(n);  // C_k − i S_k
    EXPECT_NEAR(h.harmonics[k - 1].cos_um, ck.real(), 1e-9);
    EXPECT_NEAR(h.harmonics[k - 1].sin_um, -ck.imag(), 1e-9);
  }
}

// The normal equations are built from sums of cos qθ, sin qθ (product-to-sum identities and the
// angle-addition recurrence); an explicit design matrix of std::cos(kθ), std::sin(kθ) solved by
// QR is the independent reference, on uneven sampling with a gap.
TEST(Harmonics, AgreesWithExplicitDesignMatrixLeastSquares) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = 1500, order = 10;
  std::vector<double> a, r;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * std::numbers::pi * (0.97 * i + 0.4 * u(rng)) / n - 1.0;
    a.push_back(t);
    r.push_back(3.0 * std::cos(2.0 * t - 0.4) + 0.5 * std::sin(9.0 * t) + (u(rng) - 0.5));
  }
  const auto h = FitHarmonics(a, r, order);
  Eigen::MatrixXd x(n, 2 * order + 1);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    x(i, 0) = 1.0;
    for (int k = 1; k <= order; ++k) {
      x(i, 2 * k - 1) = std::cos(k * a[i]);
      x(i, 2 * k) = std::sin(k * a[i]);
    }
    y[i] = r[i];
  }
  const Eigen::VectorXd c = x.colPivHouseholderQr().solve(y);
  EXPECT_NEAR(h.mean_um, c[0], 1e-10);
  for (int k = 1; k <= order; ++k) {
    EXPECT_NEAR(h.harmonics[k - 1].cos_um, c[2 * k - 1], 1e-10) << "order " << k;
    EXPECT_NEAR(h.harmonics[k - 1].sin_um, c[2 * k], 1e-10) << "order " << k;
  }
  EXPECT_NEAR(h.residual_rms_um, std::sqrt((y - x * c).squaredNorm() / n), 1e-12);
}

TEST(Harmonics, RejectsTooFewSamples) {
  std::vector<double> a = {0.0, 1.0, 2.0}, r = {0.0, 0.0, 0.0};
  EXPECT_ANY_THROW(FitHarmonics(a, r, 3));
}

// A model that explains the radius to the last digits: the residual's RMS is swept, not taken
// from the normal equations (whose rounding would leave ~1e-8 of a µm).
TEST(Harmonics, ExactModelLeavesNoResidual) {
  const int n = 720;
  std::vector<double> a, r;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * std::numbers::pi * i / n;
    a.push_back(t);
    r.push_back(40.0 + 3.0 * std::cos(2.0 * t - 0.4) + 0.5 * std::sin(9.0 * t));
  }
  const auto h = FitHarmonics(a, r, 10);
  EXPECT_LT(h.residual_rms_um, 1e-12);
  EXPECT_NEAR(h.harmonics[1].amplitude_um, 3.0, 1e-12);
}

}  // namespace
}  // namespace km::dbb
