// Decomposition of a volumetric error map of a 3-axis serial machine (one target point, e.g.
// the tracker's corner cube on the spindle) into geometric error components.
//
// Model, with t_a = (a − a_0)/h_a the normalised coordinate of axis a ∈ {x, y, z} (a_0 the
// centre and h_a the half range of the commanded points):
//
//   e(x, y, z) = τ + A·(p − p_0) + Σ_a Σ_{k=2..K} c_{a,k} P_k(t_a)                 (1)
//
// τ (3): translation; A (3×3) the linear part, split into scales A_aa (positioning error slope
// of axis a, ppm), squareness S_ab = −(A_ab + A_ba) (angle between +a and +b minus 90°,
// positive when larger; docs/formats.md §4, µm/m) and the rotation ω (antisymmetric part); c_{a,k}
// (3 each): positioning (component a) and straightness (the two other components) of axis a, as
// Legendre polynomials P_k of order 2..K (µm at t_a = 1). Legendre rather than monomials so
// that the slopes (scale, squareness) are those of the best-fit line over the travel, nearly
// uncorrelated with the higher orders.
//
// What a single-target map can separate: the volumetric error after the best-fit rigid
// transform has no translation and no rotation, so τ and ω are nuisance terms (≈ 0). The
// linear straightness terms of each axis are not separable from squareness and the rigid
// rotation: only their symmetric combination (the squareness) is reported. Angular errors
// (roll, pitch, yaw of each axis) act on a single target only through their Abbe arms — the
// constant tool offset and the positions of the axes further up the kinematic chain; with one
// target point and unknown offsets their constant-arm part is identical to straightness and
// positioning of the same axis, so they are NOT estimated here (fixed at zero; they appear
// inside the straightness / positioning polynomials). Separating them needs several tool
// offsets (e.g. 3 targets on the spindle) and the chain.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace km::tracker {

// Legendre polynomial P_k(t) (P_0 = 1, P_1 = t, (k+1)P_{k+1} = (2k+1) t P_k − k P_{k−1}).
inline double LegendreP(int k, double t) {
  double p0 = 1.0, p1 = t;
  if (k == 0) return p0;
  for (int n = 1; n < k; ++n) {
    const double p2 = ((2 * n + 1) * t * p1 - n * p0) / (n + 1);
    p0 = p1;
    p1 = p2;
  }
  return p1;
}

// Covariance of the volumetric errors of all points, in the low-rank form the self-calibration
// produces: Cov(e_i, e_k) = δ_ik·D_i + B_i·S·B_kᵀ (D_i 3×3, B_i 3×c, S c×c, µm²), the shared
// part coming from the tracker and dead-path parameters. Empty = errors independent.
struct VolumetricCovariance {
  std::vector<Eigen::Matrix3d> point_um2;  // D_i
  std::vector<Eigen::MatrixXd> coupling;   // B_i
  Eigen::MatrixXd shared;                  // S
  bool Empty() const { return point_um2.empty(); }
};

struct DecompositionOptions {
  int max_order = 3;  // K in eq. (1); ≥ 1 (1 = scales and squareness only)
  void Check() const;
};

struct PolynomialTerm {
  char axis = 'x';        // the moving axis a
  char direction = 'x';   // error component; == axis: positioning, else straightness
  int order = 2;          // k
  double value_um = 0.0;  // coefficient c_{a,k} (µm at the end of the range, t_a = 1)
  double sigma_um = 0.0;
};

struct GeometricDecomposition {
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_range_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d scale_ppm = Eigen::Vector3d::Zero();  // positioning slope of x, y, z
  Eigen::Vector3d scale_sigma_ppm = Eigen::Vector3d::Zero();
  // Squareness xy, yz, zx in µm/m (positive: angle between +first and +second axis > 90°).
  Eigen::Vector3d squareness_um_per_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d squareness_sigma_um_per_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotation_urad = Eigen::Vector3d::Zero();   // nuisance (≈ 0 after best fit)
  Eigen::Vector3d translation_um = Eigen::Vector3d::Zero();  // nuisance
  std::vector<PolynomialTerm> terms;
  double residual_rms_um = 0.0;
  double sigma_um = 0.0;  // a-posteriori σ of one error component (misfit of the model)
  // true: the σ of scales, squareness and terms are propagated from the given covariance of the
  // volumetric errors (correlated through the trackers) plus the model misfit; false: from the
  // misfit alone, as if the point errors were independent.
  bool propagated = false;
  std::vector<std::string> fixed;  // components not identifiable from this map, held at zero
  int dof = 0;
};

// commanded_mm and error_um of the same length; points with a non-finite error are skipped.
// Throws km::NotObservable when the points do not span enough of an axis for the model.
GeometricDecomposition DecomposeVolumetricError(const std::vector<Eigen::Vector3d>& commanded_mm,
                                                const std::vector<Eigen::Vector3d>& error_um,
                                                const DecompositionOptions& options = {},
                                                const VolumetricCovariance* covariance = nullptr);

// Evaluates eq. (1) (without τ and ω) at a commanded position: the modelled error in µm.
Eigen::Vector3d EvaluateDecomposition(const GeometricDecomposition& d,
                                      const Eigen::Vector3d& commanded_mm);

}  // namespace km::tracker
