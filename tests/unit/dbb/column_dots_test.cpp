// Several dot products at once (analysis/dbb/column_dots.h) are bit for bit Eigen's x.dot(y),
// for every length (the four-lane sums, a pair left over, an odd last element) and every count.
#include <cstring>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>

#include "analysis/dbb/column_dots.h"

namespace km::dbb::diag {
namespace {

TEST(ColumnDots, EqualEigensDotBitForBit) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  for (Eigen::Index n = 1; n <= 67; ++n) {
    Eigen::VectorXd x(n);
    std::vector<Eigen::VectorXd> y(kMaxColumnDots, Eigen::VectorXd(n));
    for (Eigen::Index i = 0; i < n; ++i) {
      x[i] = g(rng) * 1e3;
      for (auto& c : y) c[i] = g(rng);
    }
    for (int count = 1; count <= kMaxColumnDots; ++count) {
      std::vector<const double*> ys;
      for (int j = 0; j < count; ++j) ys.push_back(y[static_cast<std::size_t>(j)].data());
      std::vector<double> out(static_cast<std::size_t>(count));
      ColumnDots(x.data(), ys.data(), count, n, out.data());
      for (int j = 0; j < count; ++j) {
        const double want = x.dot(y[static_cast<std::size_t>(j)]);
        EXPECT_EQ(std::memcmp(&want, &out[static_cast<std::size_t>(j)], sizeof(double)), 0)
            << "n " << n << " count " << count << " j " << j << ": " << want << " vs "
            << out[static_cast<std::size_t>(j)];
      }
    }
  }
}

TEST(ColumnDots, AreTheInnerProducts) {
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(1001, 0.0, 1.0);
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(1001);
  const double* ys[2] = {ones.data(), x.data()};
  double out[2];
  ColumnDots(x.data(), ys, 2, x.size(), out);
  EXPECT_NEAR(out[0], 500.5, 1e-9);
  EXPECT_NEAR(out[1], 1001.0 * (1.0 / 3.0 + 1.0 / 6000.0), 1e-9);
}

}  // namespace
}  // namespace km::dbb::diag
