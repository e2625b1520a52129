#include "analysis/tracker/selfcal_problem.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>

#include "analysis/core/errors.h"

namespace km::tracker {

const char* ModeName(TrackerMode mode) {
  return mode == TrackerMode::kSequential ? "sequential" : "simultaneous";
}

SelfCalProblem SelfCalProblem::FromReadings(const TrackerReadings& readings) {
  SelfCalProblem p;
  p.num_points = readings.NumPoints();
  p.num_trackers = readings.NumTrackers();
  if (readings.displacement_um.rows() != p.num_points) {
    throw InvalidInput("", 0, "displacement_um", "one row of readings per commanded point needed");
  }
  // Segment start rows per tracker: row 0 plus every beam break.
  std::vector<std::vector<std::size_t>> starts(static_cast<std::size_t>(p.num_trackers), {0});
  for (const auto& b : readings.beam_breaks) {
    if (b.tracker < 0 || b.tracker >= p.num_trackers) {
      throw InvalidInput("", 0, "beam_break",
                         "tracker " + std::to_string(b.tracker + 1) + " does not exist");
    }
    if (b.row >= static_cast<std::size_t>(p.num_points)) {
      throw InvalidInput("", 0, "beam_break", "row " + std::to_string(b.row) + " out of range");
    }
    starts[static_cast<std::size_t>(b.tracker)].push_back(b.row);
  }
  std::vector<std::vector<int>> segment_ids(starts.size());
  for (std::size_t j = 0; j < starts.size(); ++j) {
    auto& s = starts[j];
    std::sort(s.begin(), s.end());
    s.erase(std::unique(s.begin(), s.end()), s.end());
    for (std::size_t k = 0; k < s.size(); ++k) {
      segment_ids[j].push_back(static_cast<int>(p.segment_tracker.size()));
      p.segment_tracker.push_back(static_cast<int>(j));
    }
  }
  for (int i = 0; i < p.num_points; ++i) {
    for (int j = 0; j < p.num_trackers; ++j) {
      const double d = readings.displacement_um(i, j);
      if (!std::isfinite(d)) continue;
      const auto& s = starts[static_cast<std::size_t>(j)];
      const auto it = std::upper_bound(s.begin(), s.end(), static_cast<std::size_t>(i));
      const auto k = static_cast<std::size_t>(std::distance(s.begin(), it)) - 1;
      p.observations.push_back({i, j, segment_ids[static_cast<std::size_t>(j)][k], d * 1e-3});
    }
  }
  p.active.assign(p.observations.size(), 1);
  return p;
}

std::vector<char> SelfCalProblem::PointsInUse() const {
  std::vector<char> use(static_cast<std::size_t>(num_points), 0);
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (active[k]) use[static_cast<std::size_t>(observations[k].point)] = 1;
  }
  return use;
}

std::size_t SelfCalProblem::NumActive() const {
  return static_cast<std::size_t>(std::count(active.begin(), active.end(), 1));
}

std::size_t SelfCalProblem::NumUnknowns() const {
  const auto use = PointsInUse();
  std::vector<char> seg(segment_tracker.size(), 0);
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (active[k]) seg[static_cast<std::size_t>(observations[k].segment)] = 1;
  }
  const auto points = static_cast<std::size_t>(std::count(use.begin(), use.end(), 1));
  const auto segs = static_cast<std::size_t>(std::count(seg.begin(), seg.end(), 1));
  const auto n = static_cast<std::size_t>(num_trackers);
  return 3 * points + (n >= 2 ? 3 * n - 6 + (n == 2 ? 1 : 0) : 0) + segs;
}

void SelfCalProblem::CheckCounting() const {
  const auto use = PointsInUse();
  const auto m = std::count(use.begin(), use.end(), 1);
  const auto n = num_trackers;
  const auto b = NumSegments() - n;
  const auto readings = NumActive();
  const auto unknowns = NumUnknowns();
  if (n < 4 || readings < unknowns) {
    std::ostringstream os;
    os << "laser-tracker self-calibration is not observable: the readings must satisfy "
          "m·n ≥ 3m + 4n − 6"
       << (b > 0 ? " + b" : "")
       << " (m points, n trackers, [Tracker paper] eq. 1 with one dead path per tracker"
       << (b > 0 ? ", b beam breaks" : "") << "); here m = " << m << ", n = " << n;
    if (b > 0) os << ", b = " << b;
    os << ": " << readings << " readings < " << unknowns << " unknowns";
    if (n < 4) os << " (at least 4 trackers are needed)";
    throw NotObservable(os.str());
  }
  std::vector<int> count(static_cast<std::size_t>(num_points), 0);
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (active[k]) ++count[static_cast<std::size_t>(observations[k].point)];
  }
  for (int i = 0; i < num_points; ++i) {
    const int c = count[static_cast<std::size_t>(i)];
    if (c > 0 && c < 3) {
      throw NotObservable("laser-tracker self-calibration: point row " + std::to_string(i + 1) +
                          " has only " + std::to_string(c) +
                          " readings; a point needs at least 3 trackers");
    }
  }
}

std::vector<double> SelfCalProblem::ResidualsUm(const SelfCalState& s) const {
  std::vector<double> r(observations.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (!active[k]) continue;
    const auto& o = observations[k];
    const double rho = (s.points_mm[static_cast<std::size_t>(o.point)] -
                        s.trackers_mm[static_cast<std::size_t>(o.tracker)])
                           .norm();
    r[k] = 1e3 * (rho - s.offsets_mm[static_cast<std::size_t>(o.segment)] - o.d_mm);
  }
  return r;
}

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
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(np, np);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(np);
    for (std::size_t i = 0; i < rows.c.size(); ++i) {
      const Eigen::Vector3d v = rows.c[i] - U;
      const double rho = v.norm();
      if (rho < 1e-9) continue;
      Eigen::VectorXd J = Eigen::VectorXd::Zero(np);
      J.head<3>() = -v / rho;
      J(3 + rows.seg[i]) = -1.0;
      const double r = rho - L[static_cast<std::size_t>(rows.seg[i])] - rows.d[i];
      H.noalias() += J * J.transpose();
      g.noalias() += J * r;
    }
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
  // Local segment numbering for this tracker.
  std::vector<int> local(problem.segment_tracker.size(), -1);
  int num_seg = 0;
  for (std::size_t s = 0; s < problem.segment_tracker.size(); ++s) {
    if (problem.segment_tracker[s] == tracker) local[s] = num_seg++;
  }
  TrackerRows rows;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
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

RigidTransform GaugeTransform(const std::vector<Eigen::Vector3d>& U) {
  if (U.size() < 3) throw NotObservable("the gauge needs at least 3 trackers");
  const Eigen::Vector3d a = U[1] - U[0];
  if (a.norm() < 1e-6) throw NotObservable("trackers 1 and 2 coincide; the gauge is undefined");
  const Eigen::Vector3d ex = a.normalized();
  Eigen::Vector3d v = U[2] - U[0];
  Eigen::Vector3d ey = v - v.dot(ex) * ex;
  if (ey.norm() < 1e-6 * std::max(1.0, v.norm())) {
    throw NotObservable(
        "trackers 1, 2 and 3 are collinear; the gauge (3 in the xy-plane) is "
        "undefined");
  }
  ey.normalize();
  Eigen::Vector3d ez = ex.cross(ey);
  RigidTransform T;
  if (U.size() >= 4 && ez.dot(U[3] - U[0]) < 0) {
    ez = -ez;
    T.mirrored = true;
  }
  T.rotation.row(0) = ex.transpose();
  T.rotation.row(1) = ey.transpose();
  T.rotation.row(2) = ez.transpose();
  T.translation_mm = -T.rotation * U[0];
  return T;
}

RigidTransform FitRigid(const std::vector<Eigen::Vector3d>& from,
                        const std::vector<Eigen::Vector3d>& to, const std::vector<char>* use) {
  if (to.size() != from.size() || (use && use->size() != from.size())) {
    throw InvalidInput("", 0, "points", "a rigid fit needs as many target points as points");
  }
  Eigen::Vector3d cf = Eigen::Vector3d::Zero(), ct = Eigen::Vector3d::Zero();
  double w = 0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (use && !(*use)[i]) continue;
    cf += from[i];
    ct += to[i];
    w += 1;
  }
  if (w < 3) throw NotObservable("a rigid fit needs at least 3 points");
  cf /= w;
  ct /= w;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (use && !(*use)[i]) continue;
    H += (from[i] - cf) * (to[i] - ct).transpose();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixV() * svd.matrixU().transpose();
  RigidTransform T;
  if (R.determinant() < 0) {
    const auto& s = svd.singularValues();
    if (s(2) > 1e-9 * s(0)) {
      T.mirrored = true;  // the mirror image fits better: keep it (distances cannot tell)
    } else {
      Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
      D(2, 2) = -1;
      R = svd.matrixV() * D * svd.matrixU().transpose();
    }
  }
  T.rotation = R;
  T.translation_mm = ct - R * cf;
  return T;
}

namespace {
Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}
// Covariances of the points: in the gauge (point_gauge_um2) and with the rigid motions of the
// point set projected out (point_free_um2), from the Schur blocks A⁻¹, B = A⁻¹E and S⁻¹.
void PointCovariances(const SelfCalState& state, const std::vector<char>& use,
                      const std::vector<Eigen::Matrix3d>& Ainv,
                      const std::vector<Eigen::MatrixXd>& B, const Eigen::MatrixXd& Sinv, double s2,
                      SelfCalCovariance& out) {
  const std::size_t m = use.size();
  const long c = Sinv.rows();
  // Rigid motions of the point set (about its centroid): δu_i = t + ω × v_i = G_i [t; ω].
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double cnt = 0;
  for (std::size_t i = 0; i < m; ++i) {
    if (use[i]) {
      centroid += state.points_mm[i];
      cnt += 1;
    }
  }
  centroid /= std::max(cnt, 1.0);
  auto G = [&](std::size_t i) {
    Eigen::Matrix<double, 3, 6> g;
    g.leftCols<3>().setIdentity();
    g.rightCols<3>() = -Skew(state.points_mm[i] - centroid);
    return g;
  };
  Eigen::Matrix<double, 6, 6> GtG = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::MatrixXd GB = Eigen::MatrixXd::Zero(6, c);
  Eigen::Matrix<double, 6, 6> GCG = Eigen::Matrix<double, 6, 6>::Zero();
  for (std::size_t i = 0; i < m; ++i) {
    if (!use[i]) continue;
    const auto g = G(i);
    GtG += g.transpose() * g;
    GB += g.transpose() * B[i];
    GCG += g.transpose() * Ainv[i] * g;
  }
  GCG += GB * Sinv * GB.transpose();
  const Eigen::Matrix<double, 6, 6> M = GtG.ldlt().solve(Eigen::Matrix<double, 6, 6>::Identity());
  out.point_gauge_um2.assign(m,
                             Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  out.point_free_um2 = out.point_gauge_um2;
  for (std::size_t i = 0; i < m; ++i) {
    if (!use[i]) continue;
    const Eigen::Matrix3d Cii = Ainv[i] + B[i] * Sinv * B[i].transpose();
    const auto g = G(i);
    const Eigen::Matrix<double, 6, 3> GtCi = g.transpose() * Ainv[i] + GB * Sinv * B[i].transpose();
    const Eigen::Matrix3d P1 = g * M * GtCi;
    const Eigen::Matrix3d free = Cii - P1 - P1.transpose() + g * M * GCG * M * g.transpose();
    out.point_gauge_um2[i] = s2 * Cii;
    out.point_free_um2[i] = s2 * free;
  }
}
}  // namespace

SelfCalCovariance ComputeCovariance(const SelfCalProblem& problem, const SelfCalState& state,
                                    double sigma_um) {
  const int n = problem.num_trackers;
  // Free tracker components after the gauge: tracker 2: x; tracker 3: x, y; others: x, y, z.
  std::vector<std::array<int, 3>> tidx(static_cast<std::size_t>(n), {-1, -1, -1});
  int c = 0;
  for (int j = 1; j < n; ++j) {
    const int free = j == 1 ? 1 : (j == 2 ? 2 : 3);
    for (int k = 0; k < free; ++k)
      tidx[static_cast<std::size_t>(j)][static_cast<std::size_t>(k)] = c++;
  }
  std::vector<int> sidx(problem.segment_tracker.size(), -1);
  for (std::size_t k = 0; k < problem.observations.size(); ++k) {
    if (!problem.active[k]) continue;
    auto& s = sidx[static_cast<std::size_t>(problem.observations[k].segment)];
    if (s < 0) s = c++;
  }
  const auto m = static_cast<std::size_t>(problem.num_points);
  std::vector<Eigen::Matrix3d> A(m, Eigen::Matrix3d::Zero());
  std::vector<Eigen::MatrixXd> E(m, Eigen::MatrixXd::Zero(3, c));
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(c, c);
  const auto use = problem.PointsInUse();
  for (std::size_t k = 0; k < problem.observations.size(); ++k) {
    if (!problem.active[k]) continue;
    const auto& o = problem.observations[k];
    const auto i = static_cast<std::size_t>(o.point);
    const Eigen::Vector3d u =
        (state.points_mm[i] - state.trackers_mm[static_cast<std::size_t>(o.tracker)]).normalized();
    // Row of the Jacobian: ∂r/∂u_i = uᵀ, ∂r/∂U_j = −uᵀ (free components), ∂r/∂L = −1.
    Eigen::VectorXd jc = Eigen::VectorXd::Zero(c);
    for (int a = 0; a < 3; ++a) {
      const int id = tidx[static_cast<std::size_t>(o.tracker)][static_cast<std::size_t>(a)];
      if (id >= 0) jc(id) = -u(a);
    }
    jc(sidx[static_cast<std::size_t>(o.segment)]) = -1.0;
    A[i] += u * u.transpose();
    E[i] += u * jc.transpose();
    F += jc * jc.transpose();
  }
  SelfCalCovariance out;
  out.sigma_um = sigma_um;
  const double s2 = sigma_um * sigma_um;
  std::vector<Eigen::Matrix3d> Ainv(m, Eigen::Matrix3d::Zero());
  std::vector<Eigen::MatrixXd> B(m);
  Eigen::MatrixXd S = F;
  for (std::size_t i = 0; i < m; ++i) {
    if (!use[i]) continue;
    Eigen::FullPivLU<Eigen::Matrix3d> lu(A[i]);
    if (!lu.isInvertible()) {
      throw NotObservable(
          "laser-tracker self-calibration: the tracker directions seen from point "
          "row " +
          std::to_string(i + 1) + " are coplanar (rank-deficient Jacobian)");
    }
    Ainv[i] = lu.inverse();
    B[i] = Ainv[i] * E[i];
    S.noalias() -= E[i].transpose() * B[i];
  }
  S = 0.5 * (S + S.transpose());
  if (c == 0) {
    throw NotObservable(
        "laser-tracker self-calibration: no tracker or dead-path parameter to solve");
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(S);
  const Eigen::VectorXd ev = eig.eigenvalues();
  const double lmax = ev.maxCoeff();
  const double lmin = ev.minCoeff();
  out.condition_number =
      lmin > 0 ? std::sqrt(lmax / lmin) : std::numeric_limits<double>::infinity();
  for (long k = 0; k < ev.size(); ++k) {
    if (ev(k) <= 1e-14 * lmax) ++out.rank_deficiency;
  }
  if (out.rank_deficiency > 0) return out;
  const Eigen::MatrixXd Sinv =
      eig.eigenvectors() * ev.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();

  PointCovariances(state, use, Ainv, B, Sinv, s2, out);
  out.point_block_um2.assign(m, Eigen::Matrix3d::Zero());
  out.coupling.assign(m, Eigen::MatrixXd::Zero(3, c));
  for (std::size_t i = 0; i < m; ++i) {
    if (!use[i]) continue;
    out.point_block_um2[i] = s2 * Ainv[i];
    out.coupling[i] = B[i];
  }
  out.shared_um2 = s2 * Sinv;
  out.tracker_um2.assign(static_cast<std::size_t>(n), Eigen::Matrix3d::Zero());
  for (int j = 0; j < n; ++j) {
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        const int ia = tidx[static_cast<std::size_t>(j)][static_cast<std::size_t>(a)];
        const int ib = tidx[static_cast<std::size_t>(j)][static_cast<std::size_t>(b)];
        if (ia >= 0 && ib >= 0)
          out.tracker_um2[static_cast<std::size_t>(j)](a, b) = s2 * Sinv(ia, ib);
      }
    }
  }
  return out;
}

}  // namespace km::tracker
