// Several dot products at once (analysis/dbb/column_dots.h) are bit for bit Eigen's x.dot(y),
// for every length (the four-lane sums, a pair left over, an odd last element) and every count;
// the combinations of columns are bit for bit the Eigen expressions they replace.
#include <cmath>
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

// The Eigen expressions CombineColumns replaces (diagnosis_fit.cpp FitResult::Combine).
Eigen::VectorXd CombineAsEigen(const std::vector<Eigen::VectorXd>& cols, const double* coef,
                               int count) {
  Eigen::VectorXd v = coef[0] * cols[0];
  int m = 1;
  for (; m + 3 < count; m += 4) {
    const auto j = static_cast<std::size_t>(m);
    v += coef[m] * cols[j] + coef[m + 1] * cols[j + 1] + coef[m + 2] * cols[j + 2] +
         coef[m + 3] * cols[j + 3];
  }
  for (; m < count; ++m) v += coef[m] * cols[static_cast<std::size_t>(m)];
  return v;
}

TEST(ColumnDots, CombinationEqualsEigensBitForBit) {
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  for (const Eigen::Index n : {1, 2, 3, 5, 8, 13, 64, 101}) {
    for (int count = 1; count <= 11; ++count) {
      std::vector<Eigen::VectorXd> cols(static_cast<std::size_t>(count), Eigen::VectorXd(n));
      std::vector<const double*> ptr;
      std::vector<double> coef;
      for (auto& c : cols) {
        for (Eigen::Index i = 0; i < n; ++i) c[i] = g(rng);
        ptr.push_back(c.data());
        coef.push_back(g(rng) * 10.0);
      }
      const Eigen::VectorXd want = CombineAsEigen(cols, coef.data(), count);
      Eigen::VectorXd got(n);
      CombineColumns(ptr.data(), coef.data(), count, n, got.data());
      for (Eigen::Index i = 0; i < n; ++i) {
        EXPECT_EQ(std::memcmp(&want[i], &got[i], sizeof(double)), 0)
            << "n " << n << " count " << count << " i " << i;
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

// The harmonic sums in one sweep are bit for bit the sums of the arrays the recurrence gives
// (Eigen's array expressions, then Eigen's dot with a column of ones or with r), for every
// length of tail; where the processor has no AVX2 the sweep declines.
TEST(ColumnDots, HarmonicSumsEqualTheArraySumsBitForBit) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 6.283185307179586);
  std::normal_distribution<double> g(0.0, 3.0);
  const int top = 20, rtop = 10;
  for (Eigen::Index n : {8, 9, 10, 11, 12, 13, 14, 15, 37, 3601}) {
    Eigen::ArrayXd c1(n), s1(n), r(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double t = u(rng);
      c1[i] = std::cos(t);
      s1[i] = std::sin(t);
      r[i] = g(rng);
    }
    std::vector<double> sc(top), ss(top), rc(rtop), rs(rtop);
    if (!HarmonicSums(c1.data(), s1.data(), r.data(), n, top, rtop, sc.data(), ss.data(), rc.data(),
                      rs.data())) {
      GTEST_SKIP() << "no AVX2: the sums are taken array by array";
    }
    const Eigen::VectorXd ones = Eigen::VectorXd::Ones(n);
    Eigen::ArrayXd ck = c1, sk = s1, next;
    auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; };
    for (int q = 1; q <= top; ++q) {
      if (q > 1) {
        next = ck * c1 - sk * s1;
        sk = sk * c1 + ck * s1;
        ck.swap(next);
      }
      const auto k = static_cast<std::size_t>(q - 1);
      EXPECT_TRUE(same(ones.dot(ck.matrix()), sc[k])) << "n " << n << " q " << q;
      EXPECT_TRUE(same(ones.dot(sk.matrix()), ss[k])) << "n " << n << " q " << q;
      if (q <= rtop) {
        EXPECT_TRUE(same(r.matrix().dot(ck.matrix()), rc[k])) << "n " << n << " q " << q;
        EXPECT_TRUE(same(r.matrix().dot(sk.matrix()), rs[k])) << "n " << n << " q " << q;
      }
    }
  }
}

// FusedDots (one pass for up to eight columns, fused products) and FrameDots (the columns of a
// matrix) against long-double sums, for every count and lengths that leave each tail.
TEST(ColumnDots, FusedDotsAreTheInnerProducts) {
  std::mt19937 rng(13);
  std::normal_distribution<double> nd(0.0, 1.0);
  for (const Eigen::Index n : {0, 1, 3, 4, 5, 8, 13, 1024, 3601}) {
    Eigen::MatrixXd a(n, kMaxFusedDots + 3);
    Eigen::VectorXd x(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      x[i] = nd(rng);
      for (Eigen::Index j = 0; j < a.cols(); ++j) a(i, j) = 100.0 + nd(rng);
    }
    std::vector<long double> want(static_cast<std::size_t>(a.cols()), 0.0L);
    double scale = 0.0;
    for (Eigen::Index j = 0; j < a.cols(); ++j) {
      for (Eigen::Index i = 0; i < n; ++i) {
        want[static_cast<std::size_t>(j)] += static_cast<long double>(a(i, j)) * x[i];
        scale += std::abs(a(i, j) * x[i]);
      }
    }
    const double tol = 4e-16 * scale + 1e-300;
    for (int count = 1; count <= kMaxFusedDots; ++count) {
      std::vector<const double*> ys;
      for (int j = 0; j < count; ++j) ys.push_back(a.col(j).data());
      std::vector<double> got(static_cast<std::size_t>(count));
      FusedDots(x.data(), ys.data(), count, n, got.data());
      for (int j = 0; j < count; ++j)
        EXPECT_NEAR(got[static_cast<std::size_t>(j)],
                    static_cast<double>(want[static_cast<std::size_t>(j)]), tol)
            << "n " << n << " count " << count << " column " << j;
    }
    std::vector<double> frame(static_cast<std::size_t>(a.cols()));
    FrameDots(a.data(), a.rows(), static_cast<int>(a.cols()), x.data(), n, frame.data());
    for (Eigen::Index j = 0; j < a.cols(); ++j)
      EXPECT_NEAR(frame[static_cast<std::size_t>(j)],
                  static_cast<double>(want[static_cast<std::size_t>(j)]), tol)
          << "frame n " << n << " column " << j;
  }
}

}  // namespace
}  // namespace km::dbb::diag
