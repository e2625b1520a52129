// Covariance of the self-calibration (selfcal_problem.h ComputeCovariance).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/tracker/selfcal_normal.h"
#include "analysis/tracker/selfcal_problem.h"

namespace km::tracker {

namespace {

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

// Covariances of the points: in the gauge (point_gauge_um2) and with the rigid motions of the
// point set projected out (point_free_um2), from the low-rank form Cov(u_i, u_k) =
// δ_ik·D_i + C_i S⁻¹ C_kᵀ (in units of the reading variance; C_i = out.coupling).
void PointCovariances(const SelfCalState& state, const std::vector<char>& use,
                      const std::vector<Eigen::Matrix3d>& D, const Eigen::MatrixXd& Sinv, double s2,
                      SelfCalCovariance& out) {
  const std::size_t m = use.size();
  const long c = Sinv.rows();
  // Rigid motions of the point set (about its centroid): δu_i = t + ω × v_i = G_i [t; ω].
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double cnt = 0;
  for (std::size_t i = 0; i < m; ++i) {
    if (use[i]) {
      centroid += state.points_mm[i];
      cnt += 1;
    }
  }
  centroid /= std::max(cnt, 1.0);
  auto G = [&](std::size_t i) {
    Eigen::Matrix<double, 3, 6> g;
    g.leftCols<3>().setIdentity();
    g.rightCols<3>() = -Skew(state.points_mm[i] - centroid);
    return g;
  };
  Eigen::Matrix<double, 6, 6> GtG = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::MatrixXd GB = Eigen::MatrixXd::Zero(6, c);
  Eigen::Matrix<double, 6, 6> GCG = Eigen::Matrix<double, 6, 6>::Zero();
  for (std::size_t i = 0; i < m; ++i) {
    if (!use[i]) continue;
    const auto g = G(i);
    GtG += g.transpose() * g;
    GB.noalias() += g.transpose() * out.coupling[i];
    GCG += g.transpose() * D[i] * g;
  }
  GCG += GB * Sinv * GB.transpose();
  const Eigen::Matrix<double, 6, 6> M = GtG.ldlt().solve(Eigen::Matrix<double, 6, 6>::Identity());
  const Eigen::MatrixXd GBS = GB * Sinv;
  out.point_gauge_um2.assign(m,
                             Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  out.point_free_um2 = out.point_gauge_um2;
  Eigen::MatrixXd BS;  // B·S⁻¹, kept from point to point
  for (std::size_t i = 0; i < m; ++i) {
    if (!use[i]) continue;
    const Eigen::MatrixXd& B = out.coupling[i];
    BS.noalias() = B * Sinv;
    const Eigen::Matrix3d Cii = D[i] + BS.lazyProduct(B.transpose());
    const auto g = G(i);
    const Eigen::Matrix<double, 6, 3> GtCi = g.transpose() * D[i] + GBS.lazyProduct(B.transpose());
    const Eigen::Matrix3d P1 = g * M * GtCi;
    const Eigen::Matrix3d free = Cii - P1 - P1.transpose() + g * M * GCG * M * g.transpose();
    out.point_gauge_um2[i] = s2 * Cii;
    out.point_free_um2[i] = s2 * free;
  }
}

// The gauge-fixed normal equations with the eliminated points' blocks solved out: A⁻¹ and
// B = A⁻¹E of each eliminated point, and the Schur complement S = F − EᵀA⁻¹E (per mm per mm:
// in units of the reading variance).
struct Reduced {
  std::vector<Eigen::Matrix3d> Ainv;
  selfcal_normal::RowMajorMatrix B;
  Eigen::MatrixXd S;
};

Reduced Reduce(const SelfCalProblem& problem, const selfcal_normal::ColumnLayout& L,
               const SelfCalState& state) {
  using namespace selfcal_normal;
  const long c = L.count;
  Reduced red;
  std::vector<Eigen::Matrix3d>& Ainv = red.Ainv;
  RowMajorMatrix& B = red.B;
  Eigen::MatrixXd& S = red.S;
  // The Jacobian rows (per mm per mm: in units of the reading σ), grouped by eliminated point.
  std::vector<JacobianRow> rows;
  VisitRows(problem, L, state, [&](const JacobianRow& r) { rows.push_back(r); });
  const int ne_count = L.NumEliminated();
  std::vector<std::vector<std::size_t>> of(static_cast<std::size_t>(ne_count));
  S = Eigen::MatrixXd::Zero(c, c);
  for (std::size_t q = 0; q < rows.size(); ++q) {
    JacobianRow& r = rows[q];
    r.point *= 1e-3;
    for (auto& v : r.global.val) v *= 1e-3;
    if (r.eliminated >= 0) {
      of[static_cast<std::size_t>(r.eliminated)].push_back(q);
      continue;
    }
    for (int a = 0; a < r.global.size; ++a) {
      for (int b = 0; b < r.global.size; ++b) {
        S(r.global.col[static_cast<std::size_t>(a)], r.global.col[static_cast<std::size_t>(b)]) +=
            r.global.val[static_cast<std::size_t>(a)] * r.global.val[static_cast<std::size_t>(b)];
      }
    }
  }
  // Each eliminated point: A = J_pᵀJ_p, B = A⁻¹J_pᵀJ_c, and its rows projected off its own
  // columns, J̃_c = J_c − J_p·B, add J̃_cᵀJ̃_c to S = F − EᵀA⁻¹E. (Summing the projected rows
  // instead of subtracting EᵀA⁻¹E from F keeps the small eigenvalues of S: F is larger than S
  // by far where far trackers make S ill-conditioned.)
  B = RowMajorMatrix::Zero(3 * ne_count, c);
  Ainv.resize(static_cast<std::size_t>(ne_count));
  std::vector<int> local(static_cast<std::size_t>(c), -1);
  std::vector<int> cols;
  // Buffers of one point, kept from point to point (most points have the same sizes).
  Eigen::MatrixXd Jp, Jc, JtJc, Be, P, Se;
  for (int e = 0; e < ne_count; ++e) {
    const auto& ks = of[static_cast<std::size_t>(e)];
    cols.clear();
    for (std::size_t q : ks) {
      for (int a = 0; a < rows[q].global.size; ++a) {
        const int col = rows[q].global.col[static_cast<std::size_t>(a)];
        if (local[static_cast<std::size_t>(col)] < 0) {
          local[static_cast<std::size_t>(col)] = static_cast<int>(cols.size());
          cols.push_back(col);
        }
      }
    }
    const auto k = static_cast<Eigen::Index>(ks.size());
    const auto t = static_cast<Eigen::Index>(cols.size());
    Jp.resize(k, 3);
    Jc.setZero(k, t);
    for (Eigen::Index q = 0; q < k; ++q) {
      const JacobianRow& r = rows[ks[static_cast<std::size_t>(q)]];
      Jp.row(q) = r.point.transpose();
      for (int a = 0; a < r.global.size; ++a) {
        Jc(q, local[static_cast<std::size_t>(r.global.col[static_cast<std::size_t>(a)])]) +=
            r.global.val[static_cast<std::size_t>(a)];
      }
    }
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(Jp.transpose() * Jp);
    if (!lu.isInvertible()) {
      throw NotObservable(
          "laser-tracker self-calibration: the tracker directions seen from point row " +
          std::to_string(L.eliminated_point[static_cast<std::size_t>(e)] + 1) +
          " are coplanar (rank-deficient Jacobian)");
    }
    Ainv[static_cast<std::size_t>(e)] = lu.inverse();
    JtJc.noalias() = Jp.transpose() * Jc;
    Be.noalias() = Ainv[static_cast<std::size_t>(e)] * JtJc;
    P = Jc;
    P.noalias() -= Jp * Be;
    Se.noalias() = P.transpose() * P;
    for (Eigen::Index a = 0; a < t; ++a) {
      B.block<3, 1>(3 * e, cols[static_cast<std::size_t>(a)]) = Be.col(a);
      for (Eigen::Index b = 0; b < t; ++b) {
        S(cols[static_cast<std::size_t>(a)], cols[static_cast<std::size_t>(b)]) += Se(a, b);
      }
    }
    for (int col : cols) local[static_cast<std::size_t>(col)] = -1;
  }
  S = 0.5 * (S + S.transpose()).eval();
  return red;
}

}  // namespace

SelfCalCovariance ComputeCovariance(const SelfCalProblem& problem, const SelfCalState& state,
                                    double sigma_um) {
  using namespace selfcal_normal;
  // The gauge of docs/formats.md §3: tracker 1 held, tracker 2 x only, tracker 3 x and y.
  const ColumnLayout L = MakeLayout(problem, Gauge{});
  const long c = L.count;
  const auto m = static_cast<std::size_t>(problem.num_points);
  if (c == 0) {
    throw NotObservable("laser-tracker self-calibration: no tracker parameter to solve");
  }
  SelfCalCovariance out;
  out.sigma_um = sigma_um;
  const double s2 = sigma_um * sigma_um;
  const Reduced red = Reduce(problem, L, state);
  const std::vector<Eigen::Matrix3d>& Ainv = red.Ainv;
  const RowMajorMatrix& B = red.B;
  const Eigen::MatrixXd& S = red.S;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(S);
  const Eigen::VectorXd ev = eig.eigenvalues();
  const double lmax = ev.maxCoeff();
  const double lmin = ev.minCoeff();
  out.condition_number =
      lmin > 0 ? std::sqrt(lmax / lmin) : std::numeric_limits<double>::infinity();
  for (long k = 0; k < ev.size(); ++k) {
    if (ev(k) <= 1e-14 * lmax) ++out.rank_deficiency;
  }
  if (out.rank_deficiency > 0) return out;
  const Eigen::MatrixXd Sinv =
      eig.eigenvectors() * ev.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();

  // Low-rank form: an eliminated point depends on the global columns through −B, a zero point
  // is one of them (coupling −P, P its three columns).
  const auto use = problem.PointsInUse();
  std::vector<Eigen::Matrix3d> D(m, Eigen::Matrix3d::Zero());
  out.coupling.assign(m, Eigen::MatrixXd::Zero(3, c));
  for (std::size_t i = 0; i < m; ++i) {
    if (!use[i]) continue;
    const int e = L.eliminated[i];
    if (e >= 0) {
      D[i] = Ainv[static_cast<std::size_t>(e)];
      out.coupling[i] = B.middleRows<3>(3 * e);
    } else {
      for (int a = 0; a < 3; ++a)
        out.coupling[i](a, L.point_column[i][static_cast<std::size_t>(a)]) = -1.0;
    }
  }
  PointCovariances(state, use, D, Sinv, s2, out);
  out.point_block_um2.resize(m);
  for (std::size_t i = 0; i < m; ++i) out.point_block_um2[i] = s2 * D[i];
  out.shared_um2 = s2 * Sinv;
  const int n = problem.num_trackers;
  out.tracker_um2.assign(static_cast<std::size_t>(n), Eigen::Matrix3d::Zero());
  for (int j = 0; j < n; ++j) {
    const auto& col = L.tracker_column[static_cast<std::size_t>(j)];
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        const int ia = col[static_cast<std::size_t>(a)];
        const int ib = col[static_cast<std::size_t>(b)];
        if (ia >= 0 && ib >= 0)
          out.tracker_um2[static_cast<std::size_t>(j)](a, b) = s2 * Sinv(ia, ib);
      }
    }
  }
  return out;
}

}  // namespace km::tracker
