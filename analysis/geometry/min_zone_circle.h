// Minimum-zone circularity: two concentric circles of least radial separation enclosing all
// points (ISO 12181 MZCI), computed exactly for the linearised problem.
//
// Points p_i, trial centre c. With the reference centre c0 (the least-squares centre) and
// unit vectors u_i = (p_i − c0)/|p_i − c0|, d_i = |p_i − c0|:
//   |p_i − c| = d_i − δ·u_i + ε_i,   δ = c − c0,   |ε_i| ≤ |δ|² / (2 (d_i − |δ|))
// (second-order term of the distance). The zone width f(δ) = max_i (d_i − δ·u_i) −
// min_i (d_i − δ·u_i) is convex piecewise linear, and its minimum is the linear programme
//   min h − l  s.t.  l ≤ d_i − δ·u_i ≤ h  (i = 1…N),  variables δ ∈ R², h, l free,
// solved here EXACTLY through its dual (4 equality rows, 2N non-negative weights):
//   max Σ p_i d_i − Σ q_i d_i  s.t.  Σ p_i u_i = Σ q_i u_i,  Σ p_i = 1,  Σ q_i = 1,  p, q ≥ 0
// by a revised simplex method with a 4×4 basis (p: points on the outer circle, q: inner). At
// the optimum the primal and dual objectives agree (certificate). The linearisation is then
// repeated about the new centre; for DBB traces (|δ| of a few µm on radii of 100 mm and more)
// the bound above is below 1e-9 µm after the second pass. The reported width is re-evaluated
// with the exact distances |p_i − c|.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace km::geometry {

struct MinZoneCircleResult {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double inner_radius = 0.0;
  double outer_radius = 0.0;
  double width = 0.0;                // outer − inner (exact distances)
  double linearisation_bound = 0.0;  // bound on |ε_i| at the last pass (same unit as input)
  int simplex_iterations = 0;
};

// Minimum-zone circle of the points, started from `initial_centre` (e.g. the least-squares
// centre). Needs ≥ 4 points; throws km::InvalidInput otherwise or when the points are not
// spread around the centre (the zone is then unbounded), km::DidNotConverge if the simplex
// does not terminate.
MinZoneCircleResult FitMinZoneCircle(const std::vector<Eigen::Vector2d>& points,
                                     const Eigen::Vector2d& initial_centre);

// Zone width about a fixed centre: max |p_i − c| − min |p_i − c|.
double ZoneWidthAbout(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& centre);

}  // namespace km::geometry
