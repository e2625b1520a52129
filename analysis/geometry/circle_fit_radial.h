// The least-squares circle of points that move by small amounts along fixed directions, many
// times over (a Monte Carlo run: the points of a trace p_k = p0_k + s_k·e_k, e_k the unit
// vector of the reading's direction, s_k of a few µm on radii of 100 mm and more).
//
// Init fits the unmoved points to convergence (Gauss–Newton on the orthogonal distances, as
// circle_fit.h) and keeps, for each point, what the fit needs of it: the residual r0_k about the
// base circle c0, the unit vector u_k from the base centre, a_k = e_k·u_k and b_k = e_k·t_k
// (t_k ⊥ u_k), and the sums of the base design (JᵀJ, 3 × 3, inverted once, and the moments of
// u up to the third order). A fit of moved points is then two Gauss–Newton steps from c0 in one
// O(n) pass of five sums Σ w_k·s_k:
//   step 1, the base design: d_k = r0_k + a_k·s_k, Δ1 = (JᵀJ)⁻¹ Σ J_kᵀ… (the normal equations);
//   step 2 at c0 + Δ1: its residuals to second order in Δ1 and its design turned by the centre's
//   move, both polynomials in those sums and the base moments;
// and a second pass for the residuals about c0 + Δ1 + Δ2, to second order in the moves:
//   e_k = r0_k + a_k·s_k − u_k·Δ_xy − Δ_r + (b_k·s_k − t_k·Δ_xy)²/(2R).
// What this leaves out: the turn of the design by the moves themselves (b_k·s_k/R, b ≈ the centre
// offset over R) in the steps, and the third order of the centre's move; Fit bounds both at
// every call and does the full fit (FitExact) when the bound exceeds 10⁻⁷ µm. Against the full
// fit (tests/unit/dbb/dbb_uncertainty_draw_test.cpp): within 3·10⁻⁹ µm for a ball bar's moves.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include <Eigen/Core>

namespace km::geometry {

class RadialCircleFit {
 public:
  // Points (x_k, y_k), directions (ex_k, ey_k) (unit), the fit started from `start` (centre x,
  // y, radius) and run to convergence. Throws km::DidNotConverge when it does not converge.
  void Init(std::span<const double> x, std::span<const double> y, std::span<const double> ex,
            std::span<const double> ey, const Eigen::Vector3d& start);

  std::size_t size() const { return r0_.size(); }
  const Eigen::Vector3d& base() const { return c0_; }  // centre x, y, radius of the base fit
  std::span<const double> base_residuals() const { return r0_; }

  // The fit of the moved points (centre x, y, radius) and the minimum and maximum of their
  // residuals about it, the residuals into `out` (empty: not kept). As above, or FitExact when
  // what that leaves out could exceed 10⁻⁷ µm (`exact` says which).
  struct Result {
    Eigen::Vector3d circle;
    double min, max;
    bool exact;
  };
  Result Fit(std::span<const double> s, std::span<double> out);
  // The full fit (Gauss–Newton from the base circle to convergence) and the exact residuals.
  Result FitExact(std::span<const double> s, std::span<double> out) const;

 private:
  // Sums over the base points of the unit vectors' products and of the residuals weighted by
  // them (Σ uₓ, Σ uₓuᵧ, Σ uᵧ²·r0, …).
  struct Moments {
    double n = 0, x = 0, y = 0, xx = 0, xy = 0, yy = 0, xxx = 0, xxy = 0, xyy = 0, yyy = 0;
    double r0 = 0, r0x = 0, r0y = 0, r0xy = 0, r0yy = 0;
  };
  Eigen::Vector3d c0_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d jtj_inv_ = Eigen::Matrix3d::Zero();
  std::vector<double> x0_, y0_, ex_, ey_;
  // Per point: r0, u, a = e·u, b = e·t (t ⊥ u); the weights a·(ux, uy, 1, ux·uy, uy²).
  std::vector<double> r0_, ux_, uy_, a_, b_;
  Eigen::Matrix<double, Eigen::Dynamic, 5> weights_;
  Moments moments_;
  double b_max_ = 0.0;
  std::vector<double> scratch_;
};

// One Gauss–Newton fit of the orthogonal distances of the points (x, y), from `c` (centre x, y,
// radius) until a step is below 10⁻¹² of the radius (at most 30 steps; km::DidNotConverge
// otherwise): the fit RadialCircleFit linearises about.
Eigen::Vector3d LeastSquaresCircleFrom(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y,
                                       Eigen::Vector3d c);

}  // namespace km::geometry
