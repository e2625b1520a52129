// The minimum zone (min_zone_circle.h) of points that move by small amounts along fixed
// directions, many times over (a Monte Carlo run: p_k = p0_k + s_k·e_k), exactly: the zone of
// the points near the base zone's circles (and a few spread around) is solved, then every
// point is checked against it; points outside are added and the zone solved again. The zone of
// a subset is never wider than that of all points, and one that holds every point is theirs,
// so the width is FitMinZoneCircle's of all points (to its own linearisation, 10⁻⁹ of the
// width, and the check's tolerance, 10⁻⁷ of the unit).
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include <Eigen/Core>

namespace km::geometry {

class RadialMinZone {
 public:
  // Base points p0 = (x, y), unit directions (ex, ey), the base zone's centre and the band
  // about its circles within which a moved point is taken into the first solve (the moves'
  // scale: any band gives the same width, a good one fewer rounds).
  void Init(std::span<const double> x, std::span<const double> y, std::span<const double> ex,
            std::span<const double> ey, const Eigen::Vector2d& centre, double band);

  std::size_t size() const { return d0_.size(); }

  // Width of the zone of the points p0_k + s_k·e_k.
  double Width(std::span<const double> s);

  // Width of the zone of arbitrary points `pts`, each `shift[k]` from its base distance to the
  // centre (the candidates' guide only; the check is against `pts` themselves).
  double Width(const std::vector<Eigen::Vector2d>& pts, std::span<const double> shift);

 private:
  template <class Point>
  double Solve(std::span<const double> shift, Point&& point);
  void Add(std::size_t k);

  Eigen::Vector2d centre_ = Eigen::Vector2d::Zero();
  double band_ = 0.0;
  std::vector<double> x0_, y0_, ex_, ey_, d0_, a_;  // a = e·u (u from the centre)
  std::vector<char> in_;
  std::vector<std::size_t> skeleton_, cand_;
  std::vector<Eigen::Vector2d> sub_;
  std::vector<double> v_;
};

}  // namespace km::geometry
