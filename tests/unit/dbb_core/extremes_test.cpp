// km::Extremes (analysis/core/extremes.h) against std::min / std::max from the first value on,
// and against std::minmax_element where no value is NaN, for every length that leaves a tail,
// with the extremes anywhere, NaN after the first value (passed over) and first (the result),
// infinities and equal values.
#include "analysis/core/extremes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace km {
namespace {

TEST(Extremes, AreMinmaxElementsValues) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::uniform_int_distribution<int> pick(0, 9);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (int round = 0; round < 400; ++round) {
    const std::size_t n = 1 + static_cast<std::size_t>(round % 37);
    std::vector<double> v(n);
    for (auto& x : v) {
      const int k = pick(rng);
      x = k == 0 ? nan : (k == 1 ? (pick(rng) < 5 ? inf : -inf) : (k == 2 ? 1.25 : u(rng)));
    }
    if (round % 5 == 0) v[0] = u(rng);  // a number first
    const auto [mn, mx] = Extremes(v.data(), n);
    double smn = v[0], smx = v[0];
    for (double x : v) {
      smn = std::min(smn, x);
      smx = std::max(smx, x);
    }
    if (std::isnan(v[0])) {
      EXPECT_TRUE(std::isnan(mn) && std::isnan(mx)) << round;
      continue;
    }
    EXPECT_EQ(mn, smn) << round;
    EXPECT_EQ(mx, smx) << round;
    if (std::none_of(v.begin(), v.end(), [](double x) { return std::isnan(x); })) {
      const auto [emn, emx] = std::minmax_element(v.begin(), v.end());
      EXPECT_EQ(mn, *emn) << round;
      EXPECT_EQ(mx, *emx) << round;
    }
  }
}

}  // namespace
}  // namespace km
