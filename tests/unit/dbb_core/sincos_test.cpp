// SinCos against the C library's sin and cos (correctly rounded in practice): every argument
// of a dense sweep, random ones up to 1e5 rad, the multiples of π/2 where the reduction is
// hardest, and the arguments handed to the C library (large, infinite, NaN).
#include "analysis/core/sincos.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace km::core::test {
namespace {

// |error| ≤ 2.3e-16 · max(1, |value|): the polynomials' own error (< 1 ulp of values near 1,
// a few ulp of 1 for tiny values) plus one rounding.
void ExpectClose(double x) {
  double s = 0.0, c = 0.0;
  SinCos(x, &s, &c);
  const double es = std::sin(x), ec = std::cos(x);
  EXPECT_LE(std::abs(s - es), 2.3e-16 * std::max(1.0, std::abs(es))) << "sin " << x;
  EXPECT_LE(std::abs(c - ec), 2.3e-16 * std::max(1.0, std::abs(ec))) << "cos " << x;
}

TEST(SinCos, DenseSweepOverSeveralTurns) {
  for (double x = -50.0; x <= 50.0; x += 1e-3) ExpectClose(x);
}

TEST(SinCos, RandomArgumentsUpTo1e5) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1e5, 1e5);
  for (int i = 0; i < 200000; ++i) ExpectClose(u(rng));
}

TEST(SinCos, NearMultiplesOfHalfPi) {
  for (int k = -20000; k <= 20000; k += 7) {
    const double x = k * (std::numbers::pi / 2.0);
    for (double d : {0.0, 1e-9, -1e-9, 1e-13}) ExpectClose(x + d);
  }
}

TEST(SinCos, SmallArgumentsKeepTheirRelativeAccuracy) {
  for (double x : {1e-300, 1e-20, 1e-8, -1e-5}) {
    double s = 0.0, c = 0.0;
    SinCos(x, &s, &c);
    EXPECT_NEAR(s / std::sin(x), 1.0, 1e-15);
    EXPECT_EQ(c, std::cos(x));
  }
}

TEST(SinCos, LargeAndNonFiniteArgumentsGoToTheLibrary) {
  for (double x : {1e6, -3.5e12, 1e300}) {
    double s = 0.0, c = 0.0;
    SinCos(x, &s, &c);
    EXPECT_EQ(s, std::sin(x));
    EXPECT_EQ(c, std::cos(x));
  }
  double s = 0.0, c = 0.0;
  SinCos(std::numeric_limits<double>::infinity(), &s, &c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
  SinCos(std::numeric_limits<double>::quiet_NaN(), &s, &c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
}

// The arguments of the array checks: a sweep, multiples of π/2, random ones up to 1e5 rad, and
// large and non-finite ones at odd places (an odd length, so every tail is taken).
std::vector<double> ArrayArguments() {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1e5, 1e5);
  std::vector<double> x;
  for (double v = -20.0; v <= 20.0; v += 1.37e-3) x.push_back(v);
  for (int k = -4000; k <= 4000; k += 3) x.push_back(k * (std::numbers::pi / 2.0));
  for (int i = 0; i < 100001; ++i) x.push_back(u(rng));
  for (double v : {1e6, -2e5, std::numeric_limits<double>::infinity(),
                   std::numeric_limits<double>::quiet_NaN(), 0.0, -0.0, 1e-300})
    x.push_back(v);
  return x;
}

using ArrayFunction = void (*)(const double*, double*, double*, std::size_t);

void ExpectBitForBitScalar(ArrayFunction f) {
  const std::vector<double> x = ArrayArguments();
  std::vector<double> s(x.size()), c(x.size());
  f(x.data(), s.data(), c.data(), x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    double es = 0.0, ec = 0.0;
    SinCos(x[i], &es, &ec);
    if (std::isnan(es)) {
      EXPECT_TRUE(std::isnan(s[i]) && std::isnan(c[i])) << x[i];
      continue;
    }
    EXPECT_EQ(std::signbit(s[i]), std::signbit(es)) << x[i];
    EXPECT_EQ(s[i], es) << x[i];
    EXPECT_EQ(c[i], ec) << x[i];
  }
}

// SinCosArray, whichever path the processor takes, is bit for bit SinCos; so are its two-lane
// (SSE2) and four-lane (AVX2, where the processor has it) paths each.
TEST(SinCos, ArrayIsBitForBitTheScalarOne) {
  ExpectBitForBitScalar(&SinCosArray);
}

TEST(SinCos, TwoLanePathIsBitForBitTheScalarOne) {
  ExpectBitForBitScalar(&internal::SinCosArraySse2);
}

#if KM_SINCOS_AVX2
TEST(SinCos, FourLanePathIsBitForBitTheScalarOne) {
  if (!internal::SinCosHasAvx2()) GTEST_SKIP() << "the processor has no AVX2";
  ExpectBitForBitScalar(&internal::SinCosArrayAvx2);
}
#endif

}  // namespace
}  // namespace km::core::test
