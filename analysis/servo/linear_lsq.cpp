#include "analysis/servo/linear_lsq.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "analysis/core/errors.h"

namespace km::servo {
namespace {

std::vector<int> FreeOf(const std::vector<bool>& held) {
  std::vector<int> free;
  for (int i = 0; i < static_cast<int>(held.size()); ++i)
    if (!held[static_cast<std::size_t>(i)]) free.push_back(i);
  return free;
}

// Scaled normal matrix of the free parameters.
Eigen::MatrixXd Scaled(const Eigen::MatrixXd& ata, const std::vector<int>& free,
                       Eigen::VectorXd& scale) {
  const int n = static_cast<int>(free.size());
  scale.resize(n);
  for (int i = 0; i < n; ++i) {
    const double d = ata(free[i], free[i]);
    scale[i] = d > 0.0 ? 1.0 / std::sqrt(d) : 0.0;
  }
  Eigen::MatrixXd s(n, n);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < n; ++k) s(i, k) = ata(free[i], free[k]) * scale[i] * scale[k];
  return s;
}

}  // namespace

NormalEquations::NormalEquations(int parameters)
    : ata(Eigen::MatrixXd::Zero(parameters, parameters)), atb(Eigen::VectorXd::Zero(parameters)) {}

LsqSolution SolveLeastSquares(const NormalEquations& ne, const Eigen::VectorXd& prior,
                              const std::vector<bool>& hold, double min_singular_ratio) {
  const int p = static_cast<int>(prior.size());
  std::vector<bool> held = hold;
  LsqSolution out;
  out.held_by_caller = hold;
  std::vector<int> free;
  Eigen::VectorXd scale;
  Eigen::MatrixXd s;
  for (;;) {
    free = FreeOf(held);
    if (free.empty()) break;
    s = Scaled(ne.ata, free, scale);
    int zero = -1;  // a parameter the data do not see at all
    for (int i = 0; i < static_cast<int>(free.size()); ++i)
      if (scale[i] == 0.0) zero = i;
    if (zero < 0) {
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(s);
      const double lmax = eig.eigenvalues().maxCoeff();
      const double lmin = std::max(eig.eigenvalues().minCoeff(), 0.0);
      out.condition_number = lmin > 0.0 ? std::sqrt(lmax / lmin) : INFINITY;
      if (lmin > 0.0 && std::sqrt(lmin / lmax) >= min_singular_ratio) break;
      Eigen::Index worst = 0;
      eig.eigenvectors().col(0).cwiseAbs().maxCoeff(&worst);
      zero = static_cast<int>(worst);
    }
    held[static_cast<std::size_t>(free[static_cast<std::size_t>(zero)])] = true;
    out.held.push_back(free[static_cast<std::size_t>(zero)]);
  }
  const int nf = static_cast<int>(free.size());
  if (ne.rows <= static_cast<std::size_t>(nf)) {
    throw NotObservable("servo loads: " + std::to_string(ne.rows) + " usable rows for " +
                        std::to_string(nf) + " parameters");
  }
  out.x = prior;
  Eigen::VectorXd rhs(nf);
  for (int i = 0; i < nf; ++i) {
    double r = ne.atb[free[i]];
    for (int k = 0; k < p; ++k)
      if (held[static_cast<std::size_t>(k)]) r -= ne.ata(free[i], k) * prior[k];
    rhs[i] = r * scale[i];
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(s);
  const Eigen::VectorXd z = ldlt.solve(rhs);
  for (int i = 0; i < nf; ++i) out.x[free[i]] = z[i] * scale[i];
  out.rss = std::max(0.0, ne.btb - 2.0 * out.x.dot(ne.atb) + out.x.dot(ne.ata * out.x));
  out.dof = ne.rows - static_cast<std::size_t>(nf);
  out.sigma0 = std::sqrt(out.rss / static_cast<double>(out.dof));
  const Eigen::MatrixXd sinv = ldlt.solve(Eigen::MatrixXd::Identity(nf, nf));
  out.covariance = Eigen::MatrixXd::Zero(p, p);
  out.sigma = Eigen::VectorXd::Zero(p);
  for (int i = 0; i < nf; ++i)
    for (int k = 0; k < nf; ++k)
      out.covariance(free[i], free[k]) = out.sigma0 * out.sigma0 * sinv(i, k) * scale[i] * scale[k];
  for (int i = 0; i < p; ++i) out.sigma[i] = std::sqrt(std::max(0.0, out.covariance(i, i)));
  return out;
}

}  // namespace km::servo
