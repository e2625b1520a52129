#include "analysis/dbb/harmonics.h"

#include <cmath>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/core/errors.h"

namespace km::dbb {

HarmonicsResult FitHarmonics(const std::vector<double>& angle_rad, const std::vector<double>& r_um,
                             int max_order) {
  const std::size_t n = angle_rad.size();
  if (r_um.size() != n) throw InvalidInput("", 0, "dr_um", "angle and radius sizes differ");
  if (max_order < 1) throw InvalidInput("", 0, "max_order", "must be at least 1");
  const int m = 2 * max_order + 1;
  if (n < static_cast<std::size_t>(m)) {
    throw InvalidInput("", 0, "angle_deg", "too few samples for the requested harmonic orders");
  }
  Eigen::VectorXd row(m);
  // cos kθ, sin kθ by the angle-addition recurrence (one sincos per sample).
  auto fill_row = [&](double theta) {
    const double c1 = std::cos(theta), s1 = std::sin(theta);
    double ck = 1.0, sk = 0.0;
    row[0] = 1.0;
    for (int k = 1; k <= max_order; ++k) {
      const double cn = ck * c1 - sk * s1;
      sk = sk * c1 + ck * s1;
      ck = cn;
      row[2 * k - 1] = ck;
      row[2 * k] = sk;
    }
  };
  Eigen::MatrixXd basis(m, static_cast<Eigen::Index>(n));  // one column per sample
  const Eigen::Map<const Eigen::VectorXd> r(r_um.data(), static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    fill_row(angle_rad[i]);
    basis.col(static_cast<Eigen::Index>(i)) = row;
  }
  Eigen::MatrixXd ata = Eigen::MatrixXd::Zero(m, m);
  ata.selfadjointView<Eigen::Lower>().rankUpdate(basis);
  ata.triangularView<Eigen::StrictlyUpper>() = ata.transpose();
  const Eigen::VectorXd atb = basis * r;
  Eigen::LDLT<Eigen::MatrixXd> ldlt(ata);
  if (ldlt.info() != Eigen::Success || ldlt.rcond() < 1e-12) {
    throw InvalidInput("", 0, "angle_deg", "angles do not resolve the requested harmonic orders");
  }
  const Eigen::VectorXd coef = ldlt.solve(atb);
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
  res.residual_rms_um =
      std::sqrt((r - basis.transpose() * coef).squaredNorm() / static_cast<double>(n));
  return res;
}

}  // namespace km::dbb
