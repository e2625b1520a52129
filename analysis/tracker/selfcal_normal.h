// Normal equations of the self-calibration ([Tracker paper] eqs. 3–4 written as JᵀJ·Δp = −Jᵀr),
// in the block-arrow form of bundle adjustment, shared by the solve (selfcal_solver.cpp) and the
// covariance (selfcal_covariance.cpp). Internal to the tracker library.
//
// Columns: each target point that is no interferometer's zero point is "eliminated" — its three
// coordinates couple only to the few "global" columns of its readings (the trackers, the zero
// points of the readings' segments, free dead paths) — so JᵀJ = [[A, E], [Eᵀ, F]] with A
// block-diagonal (3×3 a point) and the global block F small (3 a tracker, 3 a zero point, 1 a
// dead path). A reading of point i by tracker j, zeroed at point z, has the Jacobian row
//
//   ∂r/∂u_i = n_ijᵀ,  ∂r/∂U_j = −n_ijᵀ + n_zjᵀ,  ∂r/∂u_z = −n_zjᵀ      (n = unit vector U → u)
//
// (zeroed elsewhere: ∂r/∂U_j = −n_ijᵀ, ∂r/∂L_s = −1). Coordinates held by the gauge have no
// column: the rows and columns of A of a held point coordinate are those of the identity, with
// nothing in E and the gradient, so that its step is 0.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

#include "analysis/tracker/selfcal_problem.h"

namespace km::tracker::selfcal_normal {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Which unknown has which column. Global columns 0..count−1; eliminated points by their index.
struct ColumnLayout {
  int count = 0;                                   // global columns
  std::vector<std::array<int, 3>> tracker_column;  // per tracker; −1 = held by the gauge
  std::vector<std::array<int, 3>> point_column;    // per point: its global columns (zero points)
  std::vector<int> offset_column;                  // per segment: its dead path's column, or −1
  std::vector<int> eliminated;                     // per point: index among eliminated, or −1
  std::vector<int> eliminated_point;               // per eliminated index: the point
  std::vector<std::array<char, 3>> held;           // per eliminated index: coordinate held
  int NumEliminated() const { return static_cast<int>(eliminated_point.size()); }
};

// The gauge a layout holds: trackers (U_1 fixed, U_2 moves along x only, U_3 in the xy-plane;
// docs/formats.md §3) or three points (a fixed, b along x only, c in the xy-plane).
struct Gauge {
  bool on_points = false;
  std::array<int, 3> points{-1, -1, -1};
};

// Layout over the points and segments in use. Gauge points must be eliminated points.
ColumnLayout MakeLayout(const SelfCalProblem& problem, const Gauge& gauge);

// The global part of one Jacobian row: at most 9 columns (point, tracker, zero point).
struct GlobalRow {
  std::array<int, 9> col{};
  std::array<double, 9> val{};
  int size = 0;
  void Add(int c, double v) {
    if (c < 0) return;
    col[static_cast<std::size_t>(size)] = c;
    val[static_cast<std::size_t>(size)] = v;
    ++size;
  }
  void Add3(const std::array<int, 3>& c, const Eigen::Vector3d& v) {
    for (int a = 0; a < 3; ++a) Add(c[static_cast<std::size_t>(a)], v(a));
  }
};

// One active reading: its residual (µm), the derivatives (µm per mm) by its point's own
// coordinates (`point`, when the point is eliminated: index `eliminated` ≥ 0) and by the global
// columns.
struct JacobianRow {
  std::size_t observation = 0;
  int segment = 0;
  int eliminated = -1;
  double residual_um = 0.0;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  // n_zj (µm per mm) of a segment zeroed at a point (∂r/∂u_z = −n_zj), 0 for a dead path.
  Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  GlobalRow global;
};

// Calls visit(const JacobianRow&) for every active reading, in the order of the observations
// (FromReadings orders them by point).
template <typename Visit>
void VisitRows(const SelfCalProblem& problem, const ColumnLayout& layout, const SelfCalState& state,
               Visit&& visit) {
  // Unit vectors and lengths from each tracker to the zero point of each segment.
  const std::size_t ns = problem.segments.size();
  std::vector<Eigen::Vector3d> nz(ns, Eigen::Vector3d::Zero());
  std::vector<double> zlen(ns, 0.0);
  for (std::size_t s = 0; s < ns; ++s) {
    const Segment& g = problem.segments[s];
    if (g.FreeDeadPath()) {
      zlen[s] = state.offsets_mm[s];
      continue;
    }
    const Eigen::Vector3d v = state.points_mm[static_cast<std::size_t>(g.zero_point)] -
                              state.trackers_mm[static_cast<std::size_t>(g.tracker)];
    zlen[s] = v.norm();
    nz[s] = v / zlen[s];
  }
  JacobianRow row;
  for (std::size_t k = 0; k < problem.observations.size(); ++k) {
    if (!problem.active[k]) continue;
    const Observation& o = problem.observations[k];
    const auto i = static_cast<std::size_t>(o.point);
    const auto j = static_cast<std::size_t>(o.tracker);
    const auto s = static_cast<std::size_t>(o.segment);
    const Eigen::Vector3d v = state.points_mm[i] - state.trackers_mm[j];
    const double rho = v.norm();
    row.observation = k;
    row.segment = o.segment;
    row.residual_um = 1e3 * (rho - zlen[s] - o.d_mm);
    row.point = (1e3 / rho) * v;
    row.global.size = 0;
    const Segment& seg = problem.segments[s];
    if (seg.FreeDeadPath()) {
      row.zero.setZero();
      row.global.Add3(layout.tracker_column[j], -row.point);
      row.global.Add(layout.offset_column[s], -1e3);
    } else {
      row.zero = 1e3 * nz[s];
      row.global.Add3(layout.tracker_column[j], row.zero - row.point);
      row.global.Add3(layout.point_column[static_cast<std::size_t>(seg.zero_point)], -row.zero);
    }
    row.eliminated = layout.eliminated[i];
    if (row.eliminated < 0) {
      row.global.Add3(layout.point_column[i], row.point);
      row.point.setZero();
    }
    visit(row);
  }
}

struct NormalEquations {
  std::vector<Eigen::Matrix3d> A;  // per eliminated point
  RowMajorMatrix E;                // 3·eliminated × count
  Eigen::VectorXd g_points;        // 3·eliminated: Jᵀr of the eliminated points
  Eigen::MatrixXd F;               // count × count, symmetric
  Eigen::VectorXd g;               // count: Jᵀr of the global columns
};

// Weighted sums over the active readings at `state` (residuals in µm, lengths in mm); `weights`
// per observation (robust weights), or null for 1.
void Build(const SelfCalProblem& problem, const ColumnLayout& layout, const SelfCalState& state,
           const std::vector<double>* weights, NormalEquations& ne);

}  // namespace km::tracker::selfcal_normal
