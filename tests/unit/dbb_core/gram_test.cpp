// AddGram against sums in long double: every entry of the lower half, for column counts and row
// counts that leave every tail (rows past a multiple of four, columns past a multiple of four),
// added onto what the matrix held; the upper half untouched.
#include "analysis/core/gram.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace km::core::test {
namespace {

TEST(Gram, EveryProductOfTheColumnsAddedToTheLowerHalf) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int m : {1, 2, 3, 4, 5, 7, 9, 16, 21}) {
    for (std::size_t n : {0u, 1u, 3u, 4u, 5u, 8u, 13u, 256u, 1001u}) {
      std::vector<std::vector<double>> data(static_cast<std::size_t>(m), std::vector<double>(n));
      for (auto& c : data)
        for (double& v : c) v = u(rng);
      std::vector<const double*> cols;
      for (const auto& c : data) cols.push_back(c.data());
      const auto um = static_cast<std::size_t>(m);
      std::vector<double> g(um * um);
      for (double& v : g) v = u(rng);
      const std::vector<double> before = g;
      AddGram(cols.data(), m, n, g.data());
      for (std::size_t k = 0; k < um; ++k) {
        for (std::size_t j = 0; j < um; ++j) {
          const double got = g[k * um + j];
          if (j < k) {
            EXPECT_EQ(got, before[k * um + j]) << "upper half changed at " << j << "," << k;
            continue;
          }
          long double sum = before[k * um + j], scale = std::abs(before[k * um + j]);
          for (std::size_t i = 0; i < n; ++i) {
            sum += static_cast<long double>(data[k][i]) * data[j][i];
            scale += std::abs(data[k][i] * data[j][i]);
          }
          // Each product and addition rounded once: n + 2 roundings of the terms' magnitude.
          const double bound = static_cast<double>(n + 2) * 1.2e-16 * static_cast<double>(scale);
          EXPECT_LE(std::abs(got - static_cast<double>(sum)), bound)
              << "m " << m << " n " << n << " at " << j << "," << k;
        }
      }
    }
  }
}

}  // namespace
}  // namespace km::core::test
