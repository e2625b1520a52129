// Linear least squares from accumulated normal equations, with the identifiability report of
// docs/methods.md §12: columns are scaled to unit norm; while the smallest singular value of
// the scaled problem is below `min_singular_ratio` × the largest, the parameter that dominates
// the weakest direction is held at its prior value and named. The covariance is
// σ̂² (AᵀA)⁻¹ over the free parameters, σ̂² = RSS / (rows − free parameters).
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace km::servo {

struct NormalEquations {
  explicit NormalEquations(int parameters);
  Eigen::MatrixXd ata;
  Eigen::VectorXd atb;
  double btb = 0.0;
  std::size_t rows = 0;

  // Adds the rows a·x ≈ b.
  template <typename A, typename B>
  void Add(const A& a, const B& b) {
    ata.noalias() += a.transpose() * a;
    atb.noalias() += a.transpose() * b;
    btb += b.squaredNorm();
    rows += static_cast<std::size_t>(a.rows());
  }
};

struct LsqSolution {
  Eigen::VectorXd x;      // every parameter (held ones at their prior value)
  Eigen::VectorXd sigma;  // 0 for held parameters
  Eigen::MatrixXd covariance;
  std::vector<int> held;             // parameters the data cannot separate, held at the prior
  std::vector<bool> held_by_caller;  // per parameter
  double condition_number = 0.0;     // of the column-scaled problem, free parameters
  double rss = 0.0;
  double sigma0 = 0.0;  // residual standard deviation
  std::size_t dof = 0;
};

// `hold[i]`: held by the caller (not reported as unidentifiable). Throws km::NotObservable when
// there are no more rows than free parameters.
LsqSolution SolveLeastSquares(const NormalEquations& ne, const Eigen::VectorXd& prior,
                              const std::vector<bool>& hold, double min_singular_ratio);

}  // namespace km::servo
