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

namespace {

// Sums over the readings of one segment whose points are eliminated. A reading's global row is
// a = n_zj − n for the tracker and −n_zj for the zero point (a = −n and −1000 for a dead path),
// n_zj the same for the whole segment: its share of F and g follows from Σw, Σw·a, Σw·a·aᵀ,
// Σw·r and Σw·r·a (a formed per reading: far trackers make it a small difference).
struct SegmentSums {
  double w = 0, wr = 0;
  Eigen::Vector3d wa = Eigen::Vector3d::Zero(), wra = Eigen::Vector3d::Zero();
  Eigen::Matrix3d waa = Eigen::Matrix3d::Zero();
  Eigen::Vector3d zero = Eigen::Vector3d::Zero();
};

// F(rows, cols) += block, g(rows) += v, skipping held columns (−1).
template <int R, int C>
void AddBlock(Eigen::MatrixXd& F, const int* rows, const int* cols,
              const Eigen::Matrix<double, R, C>& block) {
  for (int a = 0; a < R; ++a) {
    if (rows[a] < 0) continue;
    for (int b = 0; b < C; ++b) {
      if (cols[b] >= 0) F(rows[a], cols[b]) += block(a, b);
    }
  }
}

template <int R>
void AddVector(Eigen::VectorXd& g, const int* rows, const Eigen::Matrix<double, R, 1>& v) {
  for (int a = 0; a < R; ++a) {
    if (rows[a] >= 0) g(rows[a]) += v(a);
  }
}

// The segments' shares of F and g, from their sums (F symmetric: both triangles).
void AddSegments(const SelfCalProblem& problem, const ColumnLayout& layout,
                 const std::vector<SegmentSums>& sums, NormalEquations& ne) {
  for (std::size_t s = 0; s < sums.size(); ++s) {
    const SegmentSums& q = sums[s];
    if (q.w == 0.0) continue;
    const Segment& seg = problem.segments[s];
    const int* t = layout.tracker_column[static_cast<std::size_t>(seg.tracker)].data();
    if (seg.FreeDeadPath()) {
      const int o[1] = {layout.offset_column[s]};
      AddBlock<3, 3>(ne.F, t, t, q.waa);
      const Eigen::Vector3d to = -1e3 * q.wa;
      AddBlock<3, 1>(ne.F, t, o, to);
      AddBlock<1, 3>(ne.F, o, t, to.transpose());
      AddBlock<1, 1>(ne.F, o, o, Eigen::Matrix<double, 1, 1>(1e6 * q.w));
      AddVector<3>(ne.g, t, q.wra);
      AddVector<1>(ne.g, o, Eigen::Matrix<double, 1, 1>(-1e3 * q.wr));
      continue;
    }
    const int* zc = layout.point_column[static_cast<std::size_t>(seg.zero_point)].data();
    const Eigen::Vector3d& z = q.zero;
    const Eigen::Matrix3d tz = -q.wa * z.transpose();
    AddBlock<3, 3>(ne.F, t, t, q.waa);
    AddBlock<3, 3>(ne.F, t, zc, tz);
    AddBlock<3, 3>(ne.F, zc, t, Eigen::Matrix3d(tz.transpose()));
    AddBlock<3, 3>(ne.F, zc, zc, Eigen::Matrix3d(q.w * z * z.transpose()));
    AddVector<3>(ne.g, t, q.wra);
    AddVector<3>(ne.g, zc, Eigen::Vector3d(-q.wr * z));
  }
}

}  // namespace

void Build(const SelfCalProblem& problem, const ColumnLayout& layout, const SelfCalState& state,
           const std::vector<double>* weights, NormalEquations& ne) {
  const int ne_count = layout.NumEliminated();
  const int c = layout.count;
  ne.A.assign(static_cast<std::size_t>(ne_count), Eigen::Matrix3d::Zero());
  ne.E.setZero(3 * ne_count, c);
  ne.g_points.setZero(3 * ne_count);
  ne.F.setZero(c, c);
  ne.g.setZero(c);
  std::vector<SegmentSums> sums(problem.segments.size());
  // A point's coordinates held by the gauge: no gradient, nothing in E.
  std::vector<Eigen::Vector3d> free(static_cast<std::size_t>(ne_count), Eigen::Vector3d::Ones());
  for (int e = 0; e < ne_count; ++e) {
    for (int a = 0; a < 3; ++a) {
      if (layout.held[static_cast<std::size_t>(e)][static_cast<std::size_t>(a)]) {
        free[static_cast<std::size_t>(e)](a) = 0.0;
      }
    }
  }
  VisitRows(problem, layout, state, [&](const JacobianRow& row) {
    const double w = weights ? (*weights)[row.observation] : 1.0;
    const double r = row.residual_um;
    const GlobalRow& gr = row.global;
    const int e = row.eliminated;
    if (e < 0) {
      // A zero point read by another tracker: every column is global.
      for (int a = 0; a < gr.size; ++a) {
        const auto ua = static_cast<std::size_t>(a);
        ne.g(gr.col[ua]) += w * gr.val[ua] * r;
        for (int b = 0; b < gr.size; ++b) {
          const auto ub = static_cast<std::size_t>(b);
          ne.F(gr.col[ua], gr.col[ub]) += w * gr.val[ua] * gr.val[ub];
        }
      }
      return;
    }
    const Eigen::Vector3d& n = row.point;
    SegmentSums& q = sums[static_cast<std::size_t>(row.segment)];
    const Eigen::Vector3d a = row.zero - n;
    const Eigen::Vector3d wa = w * a;
    q.w += w;
    q.wr += w * r;
    q.wa += wa;
    q.wra += r * wa;
    q.waa.noalias() += wa * a.transpose();
    q.zero = row.zero;
    const Eigen::Vector3d nw = (w * n).cwiseProduct(free[static_cast<std::size_t>(e)]);
    ne.A[static_cast<std::size_t>(e)].noalias() += nw * n.transpose();
    ne.g_points.segment<3>(3 * e) += r * nw;
    for (int b = 0; b < gr.size; ++b) {
      const auto ub = static_cast<std::size_t>(b);
      ne.E.block<3, 1>(3 * e, gr.col[ub]) += gr.val[ub] * nw;
    }
  });
  AddSegments(problem, layout, sums, ne);
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
