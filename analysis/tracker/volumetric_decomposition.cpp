#include "analysis/tracker/volumetric_decomposition.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>

#include <Eigen/Geometry>
#include <Eigen/QR>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"

namespace km::tracker {

void DecompositionOptions::Check() const {
  KM_OPTION_IN(max_order, 1, 8);
}

namespace {
const char kAxis[3] = {'x', 'y', 'z'};

// Columns of the design matrix: τ (3), scales (3), squareness xy/yz/zx (3), ω (3), polynomial
// terms.
struct Col {
  int kind;  // 0 τ, 1 scale, 2 squareness, 3 rotation, 4 poly
  int a, b, k;
};

// Which axes the points span and the polynomial order identifiable along each: a polynomial of
// order k needs k + 1 distinct positions. Sets the centre and half range of `out` and lists
// what cannot be identified in out.fixed.
void IdentifiableOrders(const std::vector<Eigen::Vector3d>& commanded_mm,
                        const std::vector<std::size_t>& idx, const DecompositionOptions& options,
                        std::array<int, 3>& order, std::array<bool, 3>& spans,
                        GeometricDecomposition& out) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  std::array<std::set<long long>, 3> distinct;
  for (std::size_t i : idx) {
    lo = lo.cwiseMin(commanded_mm[i]);
    hi = hi.cwiseMax(commanded_mm[i]);
    for (int a = 0; a < 3; ++a) distinct[a].insert(std::llround(commanded_mm[i](a) * 1e4));
  }
  out.centre_mm = 0.5 * (lo + hi);
  out.half_range_mm = 0.5 * (hi - lo);
  for (int a = 0; a < 3; ++a) {
    spans[a] = out.half_range_mm(a) > 1e-6 && distinct[a].size() >= 2;
    order[a] =
        spans[a] ? std::min<int>(options.max_order, static_cast<int>(distinct[a].size()) - 1) : 0;
    if (!spans[a]) {
      out.fixed.push_back(std::string("scale_") + kAxis[a] + " (points do not move along " +
                          kAxis[a] + ")");
    } else if (order[a] < options.max_order) {
      out.fixed.push_back(std::string("orders > ") + std::to_string(order[a]) + " along " +
                          kAxis[a] + " (only " + std::to_string(distinct[a].size()) +
                          " positions)");
    }
  }
  out.fixed.push_back(
      "angular errors (roll, pitch, yaw): with one target point they act only "
      "through constant Abbe arms and are absorbed in straightness/positioning");
  out.fixed.push_back(
      "linear straightness terms: only their symmetric part (squareness) is "
      "separable from the best-fit rotation");
}

// The columns the points can determine (the others are listed in out.fixed).
std::vector<Col> DesignColumns(const std::array<int, 3>& order, const std::array<bool, 3>& spans,
                               GeometricDecomposition& out) {
  std::vector<Col> cols;
  for (int a = 0; a < 3; ++a) cols.push_back({0, a, 0, 0});
  for (int a = 0; a < 3; ++a) {
    if (spans[a]) cols.push_back({1, a, 0, 0});
  }
  const int sq_pairs[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  for (int p = 0; p < 3; ++p) {
    const int a = sq_pairs[p][0], b = sq_pairs[p][1];
    if (spans[a] && spans[b]) {
      cols.push_back({2, a, b, p});
    } else {
      out.fixed.push_back(std::string("squareness_") + kAxis[a] + kAxis[b]);
    }
  }
  for (int a = 0; a < 3; ++a) cols.push_back({3, a, 0, 0});
  for (int a = 0; a < 3; ++a) {
    for (int k = 2; k <= order[a]; ++k) {
      for (int dir = 0; dir < 3; ++dir) cols.push_back({4, a, dir, k});
    }
  }
  return cols;
}

// The design matrix (3 rows a point: x, y, z of its error) and the errors it is fitted to.
void DesignMatrix(const std::vector<Eigen::Vector3d>& commanded_mm,
                  const std::vector<Eigen::Vector3d>& error_um, const std::vector<std::size_t>& idx,
                  const std::vector<Col>& cols, const GeometricDecomposition& out,
                  Eigen::MatrixXd& Aw, Eigen::VectorXd& y) {
  const long rows = 3 * static_cast<long>(idx.size());
  const long nc = static_cast<long>(cols.size());
  Aw = Eigen::MatrixXd::Zero(rows, nc);
  y.resize(rows);
  for (std::size_t r = 0; r < idx.size(); ++r) {
    const Eigen::Vector3d p = commanded_mm[idx[r]] - out.centre_mm;  // mm
    const long base = 3 * static_cast<long>(r);
    for (int a = 0; a < 3; ++a) y(base + a) = error_um[idx[r]](a);
    for (long c = 0; c < nc; ++c) {
      const Col& col = cols[static_cast<std::size_t>(c)];
      switch (col.kind) {
        case 0:
          Aw(base + col.a, c) = 1.0;
          break;
        case 1:  // ppm: µm per m = 1e-3 µm per mm
          Aw(base + col.a, c) = 1e-3 * p(col.a);
          break;
        case 2:  // A_ab = A_ba = −S/2 (µm/m)
          Aw(base + col.a, c) = -0.5e-3 * p(col.b);
          Aw(base + col.b, c) = -0.5e-3 * p(col.a);
          break;
        case 3: {  // δ = ω × p, ω in µrad
          Eigen::Vector3d w = Eigen::Vector3d::Zero();
          w(col.a) = 1e-6;
          const Eigen::Vector3d d = 1e3 * w.cross(p);  // mm → µm
          for (int q = 0; q < 3; ++q) Aw(base + q, c) = d(q);
          break;
        }
        default: {
          const double t = p(col.a) / out.half_range_mm(col.a);
          Aw(base + col.b, c) = LegendreP(col.k, t);
        }
      }
    }
  }
}

// Covariance of the coefficients: misfit σ² N⁻¹, plus (when given) the propagated covariance
// of the errors N⁻¹ (Σ A_iᵀ D_i A_i + G S Gᵀ) N⁻¹ with G = Σ A_iᵀ B_i.
Eigen::MatrixXd CoefficientCovariance(const Eigen::MatrixXd& Aw, const Eigen::VectorXd& res,
                                      const std::vector<std::size_t>& idx, std::size_t num_points,
                                      const VolumetricCovariance* covariance,
                                      GeometricDecomposition& out) {
  const long rows = Aw.rows();
  const long nc = Aw.cols();
  const Eigen::MatrixXd N = Aw.transpose() * Aw;
  const Eigen::MatrixXd Ninv = N.ldlt().solve(Eigen::MatrixXd::Identity(nc, nc));
  Eigen::MatrixXd cov_x = out.sigma_um * out.sigma_um * Ninv;
  if (covariance && !covariance->Empty()) {
    if (covariance->point_um2.size() != num_points || covariance->coupling.size() != num_points) {
      throw InvalidInput("", 0, "covariance", "one covariance block per point needed");
    }
    const long c = covariance->shared.rows();
    Eigen::MatrixXd M = Eigen::MatrixXd::Zero(nc, nc);
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(nc, c);
    for (std::size_t r = 0; r < idx.size(); ++r) {
      const auto Ai = Aw.middleRows(3 * static_cast<long>(r), 3);
      M.noalias() += Ai.transpose() * covariance->point_um2[idx[r]] * Ai;
      if (c > 0) G.noalias() += Ai.transpose() * covariance->coupling[idx[r]];
    }
    if (c > 0) M.noalias() += G * covariance->shared * G.transpose();
    const Eigen::MatrixXd prop = Ninv * M * Ninv;
    // Model misfit beyond the propagated noise (Σ tr D_i · dof/rows is what noise alone leaves).
    double expected_ss = 0;
    for (std::size_t i : idx) expected_ss += covariance->point_um2[i].trace();
    expected_ss *= static_cast<double>(out.dof) / static_cast<double>(rows);
    const double misfit2 = std::max(0.0, res.squaredNorm() - expected_ss) / std::max(out.dof, 1);
    cov_x = prop + misfit2 * Ninv;
    out.propagated = true;
  }
  return cov_x;
}

// The fitted coefficients and their σ into the named components of `out`.
void StoreCoefficients(const std::vector<Col>& cols, const Eigen::VectorXd& x,
                       const Eigen::MatrixXd& cov_x, GeometricDecomposition& out) {
  const long nc = static_cast<long>(cols.size());
  for (long c = 0; c < nc; ++c) {
    const Col& col = cols[static_cast<std::size_t>(c)];
    const double v = x(c);
    const double s = std::sqrt(std::max(cov_x(c, c), 0.0));
    switch (col.kind) {
      case 0:
        out.translation_um(col.a) = v;
        break;
      case 1:
        out.scale_ppm(col.a) = v;
        out.scale_sigma_ppm(col.a) = s;
        break;
      case 2:
        out.squareness_um_per_m(col.k) = v;
        out.squareness_sigma_um_per_m(col.k) = s;
        break;
      case 3:
        out.rotation_urad(col.a) = v;
        break;
      default:
        out.terms.push_back({kAxis[col.a], kAxis[col.b], col.k, v, s});
    }
  }
}

}  // namespace

GeometricDecomposition DecomposeVolumetricError(const std::vector<Eigen::Vector3d>& commanded_mm,
                                                const std::vector<Eigen::Vector3d>& error_um,
                                                const DecompositionOptions& options,
                                                const VolumetricCovariance* covariance) {
  options.Check();
  if (commanded_mm.size() != error_um.size()) {
    throw InvalidInput("", 0, "error_um", "one error vector per commanded point needed");
  }
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < error_um.size(); ++i) {
    if (error_um[i].allFinite() && commanded_mm[i].allFinite()) idx.push_back(i);
  }
  GeometricDecomposition out;
  if (idx.size() < 4) throw NotObservable("volumetric decomposition needs at least 4 points");
  std::array<int, 3> order{};
  std::array<bool, 3> spans{};
  IdentifiableOrders(commanded_mm, idx, options, order, spans, out);
  const std::vector<Col> cols = DesignColumns(order, spans, out);
  const long rows = 3 * static_cast<long>(idx.size());
  const long nc = static_cast<long>(cols.size());
  Eigen::MatrixXd Aw;
  Eigen::VectorXd y;
  DesignMatrix(commanded_mm, error_um, idx, cols, out, Aw, y);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Aw);
  qr.setThreshold(1e-10);
  if (qr.rank() < nc) {
    throw NotObservable(
        "volumetric decomposition: the commanded points do not determine the "
        "geometric error components (rank " +
        std::to_string(qr.rank()) + " of " + std::to_string(nc) + ")");
  }
  const Eigen::VectorXd x = qr.solve(y);
  const Eigen::VectorXd res = y - Aw * x;
  out.dof = static_cast<int>(rows - nc);
  out.residual_rms_um = std::sqrt(res.squaredNorm() / static_cast<double>(rows));
  out.sigma_um = out.dof > 0 ? std::sqrt(res.squaredNorm() / out.dof) : 0.0;
  const Eigen::MatrixXd cov_x =
      CoefficientCovariance(Aw, res, idx, commanded_mm.size(), covariance, out);
  StoreCoefficients(cols, x, cov_x, out);
  return out;
}

Eigen::Vector3d EvaluateDecomposition(const GeometricDecomposition& d,
                                      const Eigen::Vector3d& commanded_mm) {
  const Eigen::Vector3d p = commanded_mm - d.centre_mm;
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  for (int a = 0; a < 3; ++a) e(a) += 1e-3 * d.scale_ppm(a) * p(a);
  const int sq_pairs[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  for (int q = 0; q < 3; ++q) {
    const int a = sq_pairs[q][0], b = sq_pairs[q][1];
    e(a) += -0.5e-3 * d.squareness_um_per_m(q) * p(b);
    e(b) += -0.5e-3 * d.squareness_um_per_m(q) * p(a);
  }
  for (const auto& t : d.terms) {
    const int a = t.axis - 'x', b = t.direction - 'x';
    if (d.half_range_mm(a) <= 0) continue;
    e(b) += t.value_um * LegendreP(t.order, p(a) / d.half_range_mm(a));
  }
  return e;
}

}  // namespace km::tracker
