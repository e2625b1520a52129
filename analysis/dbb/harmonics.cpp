#include "analysis/dbb/harmonics.h"

#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/core/errors.h"
#include "analysis/dbb/column_dots.h"

namespace km::dbb {

namespace {

using Eigen::ArrayXd;

// Sums over the samples of cos qθ and sin qθ (q = 0 … 2N) and the right-hand side Σ r·{1,
// cos kθ, sin kθ} (k ≤ N). The angle-addition recurrence runs over whole sample arrays, so
// each order costs a few vector operations and no trigonometric call.
struct HarmonicSums {
  std::vector<double> c, s;  // Σ cos qθ, Σ sin qθ
  Eigen::VectorXd atb;
};

HarmonicSums SumHarmonics(const Eigen::Ref<const ArrayXd>& c1, const Eigen::Ref<const ArrayXd>& s1,
                          const Eigen::Ref<const ArrayXd>& r, int max_order) {
  HarmonicSums h;
  const auto top = static_cast<std::size_t>(2 * max_order);
  h.c.assign(top + 1, 0.0);
  h.s.assign(top + 1, 0.0);
  h.atb.resize(2 * max_order + 1);
  h.c[0] = static_cast<double>(c1.size());
  h.atb[0] = r.sum();
  // One sweep with the recurrence in registers where the processor allows (the same sums).
  std::vector<double> rc(static_cast<std::size_t>(max_order)), rs(rc.size());
  if (diag::HarmonicSums(c1.data(), s1.data(), r.data(), c1.size(), static_cast<int>(top),
                         max_order, h.c.data() + 1, h.s.data() + 1, rc.data(), rs.data())) {
    for (int k = 1; k <= max_order; ++k) {
      h.atb[2 * k - 1] = rc[static_cast<std::size_t>(k - 1)];
      h.atb[2 * k] = rs[static_cast<std::size_t>(k - 1)];
    }
    return h;
  }
  ArrayXd ck = c1, sk = s1, next;
  // Σ cos qθ and Σ sin qθ at once, Σ r cos kθ and Σ r sin kθ at once (column_dots.h: each sum
  // as Eigen's; a sum is the inner product with ones, the products by 1 exact).
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(c1.size());
  double sums[2];
  for (std::size_t q = 1; q <= top; ++q) {
    if (q > 1) {
      next = ck * c1 - sk * s1;
      sk = sk * c1 + ck * s1;
      ck.swap(next);
    }
    const double* both[2] = {ck.data(), sk.data()};
    diag::ColumnDots(ones.data(), both, 2, ck.size(), sums);
    h.c[q] = sums[0];
    h.s[q] = sums[1];
    if (q <= static_cast<std::size_t>(max_order)) {
      diag::ColumnDots(r.data(), both, 2, ck.size(), sums);
      h.atb[static_cast<Eigen::Index>(2 * q - 1)] = sums[0];
      h.atb[static_cast<Eigen::Index>(2 * q)] = sums[1];
    }
  }
  return h;
}

// Normal matrix of the basis {1, cos kθ, sin kθ} from the sums, by the product-to-sum
// identities: cos jθ cos kθ = ½[cos (j−k)θ + cos (j+k)θ], sin jθ sin kθ = ½[cos (j−k)θ −
// cos (j+k)θ], cos jθ sin kθ = ½[sin (j+k)θ − sin (j−k)θ].
Eigen::MatrixXd NormalMatrix(const HarmonicSums& h, int max_order) {
  const int m = 2 * max_order + 1;
  auto C = [&](int q) { return h.c[static_cast<std::size_t>(std::abs(q))]; };
  auto S = [&](int q) {
    return q < 0 ? -h.s[static_cast<std::size_t>(-q)] : h.s[static_cast<std::size_t>(q)];
  };
  Eigen::MatrixXd g(m, m);
  g(0, 0) = C(0);
  for (int k = 1; k <= max_order; ++k) {
    g(0, 2 * k - 1) = g(2 * k - 1, 0) = C(k);
    g(0, 2 * k) = g(2 * k, 0) = S(k);
    for (int j = 1; j <= max_order; ++j) {
      g(2 * j - 1, 2 * k - 1) = 0.5 * (C(j - k) + C(j + k));
      g(2 * j, 2 * k) = 0.5 * (C(j - k) - C(j + k));
      g(2 * j - 1, 2 * k) = 0.5 * (S(j + k) - S(j - k));
    }
  }
  for (int j = 1; j <= max_order; ++j)
    for (int k = 1; k <= max_order; ++k) g(2 * k, 2 * j - 1) = g(2 * j - 1, 2 * k);
  return g;
}

// r − model over the samples, by the same recurrence.
double SweptResidualRms(const Eigen::Ref<const ArrayXd>& c1, const Eigen::Ref<const ArrayXd>& s1,
                        const Eigen::Ref<const ArrayXd>& r, const Eigen::VectorXd& coef,
                        int max_order) {
  ArrayXd res = r - coef[0];
  ArrayXd ck = c1, sk = s1, next;
  for (int k = 1; k <= max_order; ++k) {
    if (k > 1) {
      next = ck * c1 - sk * s1;
      sk = sk * c1 + ck * s1;
      ck.swap(next);
    }
    res -= coef[2 * k - 1] * ck + coef[2 * k] * sk;
  }
  return std::sqrt(res.square().sum() / static_cast<double>(r.size()));
}

// RMS of r − model from the sums already taken, RSS = rᵀr − 2 coefᵀAᵀr + coefᵀ(AᵀA)coef (the
// fit's normal matrix and right-hand side), so the samples are not swept again. Its rounding is
// ~1e-16 rᵀr: when the model explains all but 1e-6 of rᵀr the residual is swept instead.
double ResidualRms(const Eigen::Ref<const ArrayXd>& c1, const Eigen::Ref<const ArrayXd>& s1,
                   const Eigen::Ref<const ArrayXd>& r, const Eigen::MatrixXd& normal,
                   const HarmonicSums& h, const Eigen::VectorXd& coef, int max_order) {
  const double rr = r.matrix().squaredNorm();
  const double rss = rr - 2.0 * coef.dot(h.atb) + coef.dot(normal * coef);
  if (!(rss > 1e-6 * rr)) return SweptResidualRms(c1, s1, r, coef, max_order);
  return std::sqrt(rss / static_cast<double>(r.size()));
}

}  // namespace

HarmonicsResult FitHarmonics(const std::vector<double>& angle_rad, const std::vector<double>& r_um,
                             int max_order) {
  std::vector<double> c(angle_rad.size()), s(angle_rad.size());
  for (std::size_t i = 0; i < angle_rad.size(); ++i) {
    c[i] = std::cos(angle_rad[i]);
    s[i] = std::sin(angle_rad[i]);
  }
  return FitHarmonics(c, s, r_um, max_order);
}

HarmonicsResult FitHarmonics(const std::vector<double>& cos_angle,
                             const std::vector<double>& sin_angle, const std::vector<double>& r_um,
                             int max_order) {
  const std::size_t n = cos_angle.size();
  if (r_um.size() != n || sin_angle.size() != n) {
    throw InvalidInput("", 0, "dr_um", "angle and radius sizes differ");
  }
  if (max_order < 1) throw InvalidInput("", 0, "max_order", "must be at least 1");
  const int m = 2 * max_order + 1;
  if (n < static_cast<std::size_t>(m)) {
    throw InvalidInput("", 0, "angle_deg", "too few samples for the requested harmonic orders");
  }
  const auto len = static_cast<Eigen::Index>(n);
  const Eigen::Map<const ArrayXd> c1(cos_angle.data(), len);
  const Eigen::Map<const ArrayXd> s1(sin_angle.data(), len);
  const Eigen::Map<const ArrayXd> r(r_um.data(), len);
  const HarmonicSums sums = SumHarmonics(c1, s1, r, max_order);
  const Eigen::MatrixXd normal = NormalMatrix(sums, max_order);
  Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
  if (ldlt.info() != Eigen::Success || ldlt.rcond() < 1e-12) {
    throw InvalidInput("", 0, "angle_deg", "angles do not resolve the requested harmonic orders");
  }
  const Eigen::VectorXd coef = ldlt.solve(sums.atb);
  HarmonicsResult res;
  res.mean_um = coef[0];
  for (int k = 1; k <= max_order; ++k) {
    Harmonic h;
    h.order = k;
    h.cos_um = coef[2 * k - 1];
    h.sin_um = coef[2 * k];
    h.amplitude_um = std::hypot(h.cos_um, h.sin_um);
    double ph = std::atan2(h.sin_um, h.cos_um) * 180.0 / std::numbers::pi;
    if (ph < 0.0) ph += 360.0;
    h.phase_deg = ph;
    res.harmonics.push_back(h);
  }
  res.residual_rms_um = ResidualRms(c1, s1, r, normal, sums, coef, max_order);
  return res;
}

}  // namespace km::dbb
