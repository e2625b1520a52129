// Initial tracker positions from the commanded points (selfcal_problem.h InitialiseTracker).
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/SVD>

#include "analysis/core/errors.h"
#include "analysis/tracker/selfcal_problem.h"

namespace km::tracker {

namespace {

struct TrackerRows {
  std::vector<Eigen::Vector3d> c;
  std::vector<double> d;
  std::vector<int> seg;  // local segment index
};

// Levenberg-Marquardt on |c_i − U| − L_seg(i) − d_i; returns the rms in mm.
double RefineTracker(const TrackerRows& rows, int num_seg, Eigen::Vector3d& U,
                     std::vector<double>& L, int max_iter = 60) {
  const int np = 3 + num_seg;
  auto cost = [&](const Eigen::Vector3d& u, const std::vector<double>& l) {
    double s = 0;
    for (std::size_t i = 0; i < rows.c.size(); ++i) {
      const double r =
          (rows.c[i] - u).norm() - l[static_cast<std::size_t>(rows.seg[i])] - rows.d[i];
      s += r * r;
    }
    return s;
  };
  double f = cost(U, L);
  double lambda = 1e-3;
  for (int it = 0; it < max_iter; ++it) {
    // Normal equations of the rows (∂r/∂U = −n, ∂r/∂L_seg = −1), accumulated without a
    // Jacobian row per reading.
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(np, np);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(np);
    Eigen::Matrix3d Huu = Eigen::Matrix3d::Zero();
    Eigen::Vector3d gu = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < rows.c.size(); ++i) {
      const Eigen::Vector3d v = rows.c[i] - U;
      const double rho = v.norm();
      if (rho < 1e-9) continue;
      const Eigen::Vector3d n = v / rho;
      const int s = 3 + rows.seg[i];
      const double r = rho - L[static_cast<std::size_t>(rows.seg[i])] - rows.d[i];
      Huu.noalias() += n * n.transpose();
      gu -= n * r;
      H.block<3, 1>(0, s) += n;
      H(s, s) += 1.0;
      g(s) -= r;
    }
    H.topLeftCorner<3, 3>() = Huu;
    H.bottomLeftCorner(num_seg, 3) = H.topRightCorner(3, num_seg).transpose();
    g.head<3>() = gu;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::MatrixXd A = H;
      A.diagonal() += lambda * H.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd step = -A.ldlt().solve(g);
      if (!step.allFinite()) break;
      Eigen::Vector3d U2 = U + step.head<3>();
      std::vector<double> L2 = L;
      for (int k = 0; k < num_seg; ++k) L2[static_cast<std::size_t>(k)] += step(3 + k);
      const double f2 = cost(U2, L2);
      if (f2 < f) {
        const double rel = (f - f2) / std::max(f, 1e-300);
        U = U2;
        L = L2;
        f = f2;
        lambda = std::max(lambda * 0.3, 1e-9);
        improved = true;
        if (rel < 1e-12 || step.norm() < 1e-9) return std::sqrt(f / rows.c.size());
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  return std::sqrt(f / std::max<std::size_t>(rows.c.size(), 1));
}

void OffsetsFromPosition(const TrackerRows& rows, int num_seg, const Eigen::Vector3d& U,
                         std::vector<double>& L) {
  L.assign(static_cast<std::size_t>(num_seg), 0.0);
  std::vector<std::vector<double>> v(static_cast<std::size_t>(num_seg));
  for (std::size_t i = 0; i < rows.c.size(); ++i) {
    v[static_cast<std::size_t>(rows.seg[i])].push_back((rows.c[i] - U).norm() - rows.d[i]);
  }
  for (int k = 0; k < num_seg; ++k) {
    auto& x = v[static_cast<std::size_t>(k)];
    if (x.empty()) continue;
    std::nth_element(x.begin(), x.begin() + static_cast<long>(x.size() / 2), x.end());
    L[static_cast<std::size_t>(k)] = x[x.size() / 2];
  }
}

}  // namespace

TrackerInit InitialiseTracker(const SelfCalProblem& problem, const TrackerReadings& readings,
                              int tracker, const Eigen::Vector3d* guess_mm) {
  // Local segment numbering for this tracker; a segment zeroed at a point has its zero reading
  // there as a row (d = 0), the start fits an offset per segment in any case.
  std::vector<int> local(problem.segments.size(), -1);
  int num_seg = 0;
  TrackerRows rows;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (std::size_t s = 0; s < problem.segments.size(); ++s) {
    const Segment& g = problem.segments[s];
    if (g.tracker != tracker) continue;
    local[s] = num_seg++;
    if (g.FreeDeadPath()) continue;
    rows.c.push_back(readings.commanded_mm[static_cast<std::size_t>(g.zero_point)]);
    rows.d.push_back(0.0);
    rows.seg.push_back(local[s]);
    centre += rows.c.back();
  }
  for (std::size_t k = 0; k < problem.observations.size(); ++k) {
    const auto& o = problem.observations[k];
    if (o.tracker != tracker || !problem.active[k]) continue;
    rows.c.push_back(readings.commanded_mm[static_cast<std::size_t>(o.point)]);
    rows.d.push_back(o.d_mm);
    rows.seg.push_back(local[static_cast<std::size_t>(o.segment)]);
    centre += rows.c.back();
  }
  if (rows.c.size() < 5) {
    throw NotObservable("laser-tracker self-calibration: tracker " + std::to_string(tracker + 1) +
                        " has fewer than 5 readings; its position cannot be initialised");
  }
  centre /= static_cast<double>(rows.c.size());
  double extent = 0;
  for (const auto& c : rows.c) extent = std::max(extent, (c - centre).norm());

  TrackerInit best;
  best.rms_um = std::numeric_limits<double>::infinity();
  auto try_start = [&](const Eigen::Vector3d& U0) {
    Eigen::Vector3d U = U0;
    std::vector<double> L;
    OffsetsFromPosition(rows, num_seg, U, L);
    const double rms = 1e3 * RefineTracker(rows, num_seg, U, L);
    if (std::isfinite(rms) && rms < best.rms_um) {
      best.position_mm = U;
      best.offsets_mm = L;
      best.rms_um = rms;
    }
  };

  if (guess_mm) {
    try_start(*guess_mm);
    if (!std::isfinite(best.rms_um) ||
        best.offsets_mm.size() != static_cast<std::size_t>(num_seg)) {
      throw DidNotConverge(
          "laser-tracker self-calibration: the fit from the guessed position of "
          "tracker " +
          std::to_string(tracker + 1) +
          " failed (tracker_guess_mm); give a rough position in the machine "
          "frame of the commanded points, or leave the guess out");
    }
    return best;
  }
  if (num_seg < 1) {
    throw NotObservable("laser-tracker self-calibration: tracker " + std::to_string(tracker + 1) +
                        " has no interferometer segment");
  }
  // Closed form on the largest segment: 2cᵀU + 2dL − (|U|² − L²) = |c|² − d² (centred c).
  std::vector<int> seg_count(static_cast<std::size_t>(num_seg), 0);
  for (int s : rows.seg) ++seg_count[static_cast<std::size_t>(s)];
  const int big =
      static_cast<int>(std::max_element(seg_count.begin(), seg_count.end()) - seg_count.begin());
  {
    std::vector<std::size_t> idx;
    for (std::size_t i = 0; i < rows.c.size(); ++i) {
      if (rows.seg[i] == big) idx.push_back(i);
    }
    if (idx.size() >= 6) {
      Eigen::MatrixXd A(static_cast<long>(idx.size()), 5);
      Eigen::VectorXd b(static_cast<long>(idx.size()));
      const double sc = std::max(extent, 1.0);
      for (std::size_t r = 0; r < idx.size(); ++r) {
        const Eigen::Vector3d c = (rows.c[idx[r]] - centre) / sc;
        const double d = rows.d[idx[r]] / sc;
        A.row(static_cast<long>(r)) << 2 * c.x(), 2 * c.y(), 2 * c.z(), 2 * d, -1.0;
        b(static_cast<long>(r)) = c.squaredNorm() - d * d;
      }
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
      const auto& sv = svd.singularValues();
      if (sv(4) > 1e-12 * sv(0)) {
        const Eigen::VectorXd x = svd.solve(b);
        if (x.allFinite()) try_start(centre + sc * x.head<3>());
      }
    }
  }
  // Fits worse than 100 µm rms (or no closed form): starts on shells around the work volume.
  if (best.rms_um > 100.0) {
    for (double radius : {400.0, 800.0, 1200.0, 1600.0}) {
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dz = -1; dz <= 1; ++dz) {
            if (dx == 0 && dy == 0 && dz == 0) continue;
            const Eigen::Vector3d dir = Eigen::Vector3d(dx, dy, dz).normalized();
            try_start(centre + (radius + extent) * dir);
          }
        }
      }
    }
  }
  if (!std::isfinite(best.rms_um) || best.offsets_mm.size() != static_cast<std::size_t>(num_seg)) {
    throw DidNotConverge("laser-tracker self-calibration: no initial position found for tracker " +
                         std::to_string(tracker + 1));
  }
  return best;
}

}  // namespace km::tracker
