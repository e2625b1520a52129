#include "analysis/tracker/selfcal_normal.h"

#include <algorithm>

namespace km::tracker::selfcal_normal {

ColumnLayout MakeLayout(const SelfCalProblem& problem, const Gauge& gauge) {
  ColumnLayout L;
  const auto m = static_cast<std::size_t>(problem.num_points);
  const auto n = static_cast<std::size_t>(problem.num_trackers);
  const auto use = problem.PointsInUse();
  const auto seg_use = problem.SegmentsInUse();
  std::vector<char> is_zero(m, 0);
  for (std::size_t s = 0; s < problem.segments.size(); ++s) {
    const int z = problem.segments[s].zero_point;
    if (seg_use[s] && z >= 0) is_zero[static_cast<std::size_t>(z)] = 1;
  }
  L.tracker_column.assign(n, {-1, -1, -1});
  for (std::size_t j = 0; j < n; ++j) {
    // Tracker gauge: tracker 1 held, tracker 2 x only, tracker 3 x and y.
    const int free = gauge.on_points ? 3 : std::min<int>(static_cast<int>(j), 3);
    for (int a = 0; a < free; ++a) L.tracker_column[j][static_cast<std::size_t>(a)] = L.count++;
  }
  L.point_column.assign(m, {-1, -1, -1});
  L.eliminated.assign(m, -1);
  for (std::size_t i = 0; i < m; ++i) {
    if (!use[i]) continue;
    if (is_zero[i]) {
      for (int a = 0; a < 3; ++a) L.point_column[i][static_cast<std::size_t>(a)] = L.count++;
      continue;
    }
    L.eliminated[i] = L.NumEliminated();
    L.eliminated_point.push_back(static_cast<int>(i));
    L.held.push_back({0, 0, 0});
  }
  L.offset_column.assign(problem.segments.size(), -1);
  for (std::size_t s = 0; s < problem.segments.size(); ++s) {
    if (seg_use[s] && problem.segments[s].FreeDeadPath()) L.offset_column[s] = L.count++;
  }
  if (gauge.on_points) {
    // a: all three held; b: y and z; c: z.
    for (int q = 0; q < 3; ++q) {
      const int e =
          L.eliminated[static_cast<std::size_t>(gauge.points[static_cast<std::size_t>(q)])];
      for (int a = q; a < 3; ++a) {
        L.held[static_cast<std::size_t>(e)][static_cast<std::size_t>(a)] = 1;
      }
    }
  }
  return L;
}

void Build(const SelfCalProblem& problem, const ColumnLayout& layout, const SelfCalState& state,
           const std::vector<double>* weights, NormalEquations& ne) {
  const int ne_count = layout.NumEliminated();
  const int c = layout.count;
  ne.A.assign(static_cast<std::size_t>(ne_count), Eigen::Matrix3d::Zero());
  ne.E.setZero(3 * ne_count, c);
  ne.g_points.setZero(3 * ne_count);
  ne.F.setZero(c, c);
  ne.g.setZero(c);
  VisitRows(problem, layout, state, [&](const JacobianRow& row) {
    const double w = weights ? (*weights)[row.observation] : 1.0;
    const double r = row.residual_um;
    const GlobalRow& gr = row.global;
    for (int a = 0; a < gr.size; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      ne.g(gr.col[ua]) += w * gr.val[ua] * r;
      for (int b = 0; b < gr.size; ++b) {
        const auto ub = static_cast<std::size_t>(b);
        if (gr.col[ub] <= gr.col[ua]) ne.F(gr.col[ua], gr.col[ub]) += w * gr.val[ua] * gr.val[ub];
      }
    }
    const int e = row.eliminated;
    if (e < 0) return;
    const auto& held = layout.held[static_cast<std::size_t>(e)];
    Eigen::Vector3d nw = w * row.point;
    for (int a = 0; a < 3; ++a) {
      if (held[static_cast<std::size_t>(a)]) nw(a) = 0.0;
    }
    ne.A[static_cast<std::size_t>(e)].noalias() += nw * row.point.transpose();
    ne.g_points.segment<3>(3 * e) += nw * r;
    for (int b = 0; b < gr.size; ++b) {
      const auto ub = static_cast<std::size_t>(b);
      for (int a = 0; a < 3; ++a) ne.E(3 * e + a, gr.col[ub]) += nw(a) * gr.val[ub];
    }
  });
  // Held coordinates: identity rows and columns.
  for (int e = 0; e < ne_count; ++e) {
    Eigen::Matrix3d& A = ne.A[static_cast<std::size_t>(e)];
    for (int a = 0; a < 3; ++a) {
      if (!layout.held[static_cast<std::size_t>(e)][static_cast<std::size_t>(a)]) continue;
      A.row(a).setZero();
      A.col(a).setZero();
      A(a, a) = 1.0;
    }
  }
}

}  // namespace km::tracker::selfcal_normal
