// Rejection of readings on their own evidence (tracker_selfcal.h): residuals standardised by
// their leverage, the robust threshold, and the re-estimation of a point without each of its
// readings. Stages of SelfCalibrate (tracker_selfcal_stages.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "analysis/tracker/tracker_selfcal_stages.h"

namespace km::tracker::selfcal_stages {
namespace {

double MedianAbs(const std::vector<double>& r) {
  std::vector<double> a;
  a.reserve(r.size());
  for (double x : r) {
    if (std::isfinite(x)) a.push_back(std::abs(x));
  }
  if (a.empty()) return 0.0;
  std::nth_element(a.begin(), a.begin() + static_cast<long>(a.size() / 2), a.end());
  return a[a.size() / 2];
}

}  // namespace

// Residuals divided by √(1 − h), h the leverage of the reading within its point block
// (h = nᵀ A⁻¹ n, A = Σ n nᵀ over the point's active readings; the shared tracker parameters
// add little). Readings without redundancy (1 − h ≈ 0) get 0: they cannot be tested, and are
// marked in `testable` (when given) so that they do not enter the robust σ. (Far trackers can
// leave half the readings of every point without redundancy: counting their zeros would shrink
// the σ and reject clean readings.)
std::vector<double> StandardisedResiduals(const SelfCalProblem& problem, const SelfCalState& state,
                                          const std::vector<double>& r,
                                          std::vector<char>* testable) {
  const auto m = static_cast<std::size_t>(problem.num_points);
  std::vector<Eigen::Matrix3d> A(m, Eigen::Matrix3d::Zero());
  std::vector<Eigen::Vector3d> dir(problem.observations.size(), Eigen::Vector3d::Zero());
  for (std::size_t k = 0; k < problem.observations.size(); ++k) {
    if (!problem.active[k]) continue;
    const auto& o = problem.observations[k];
    dir[k] = (state.points_mm[static_cast<std::size_t>(o.point)] -
              state.trackers_mm[static_cast<std::size_t>(o.tracker)])
                 .normalized();
    A[static_cast<std::size_t>(o.point)] += dir[k] * dir[k].transpose();
  }
  std::vector<Eigen::Matrix3d> Ainv(m);
  for (std::size_t i = 0; i < m; ++i) {
    Eigen::FullPivLU<Eigen::Matrix3d> lu(A[i]);
    Ainv[i] = lu.isInvertible() ? Eigen::Matrix3d(lu.inverse()) : Eigen::Matrix3d::Zero();
  }
  std::vector<double> z(r.size(), kNaN);
  if (testable) testable->assign(r.size(), 0);
  for (std::size_t k = 0; k < r.size(); ++k) {
    if (!problem.active[k]) continue;
    const double h =
        dir[k].dot(Ainv[static_cast<std::size_t>(problem.observations[k].point)] * dir[k]);
    z[k] = 1.0 - h > 1e-3 ? r[k] / std::sqrt(1.0 - h) : 0.0;
    if (testable) (*testable)[k] = 1.0 - h > 1e-3;
  }
  return z;
}

namespace {

// Of a point's active readings `ks` (≥ 5), those the other trackers' view of the point disagrees
// with: the point is re-estimated from all its readings but one (trackers and zero lengths held),
// for each reading in turn, and the reading whose omission leaves the others most consistent
// (sum of squared residuals within (redundancy)·tau²) is returned; pairs as below. The largest
// standardised residual alone may point at a good reading when a robust pass has settled the
// point in the wrong place.
std::vector<std::size_t> LeastConsistentReadings(const SelfCalProblem& problem,
                                                 const SelfCalState& state, int point,
                                                 const std::vector<std::size_t>& ks,
                                                 double tau_um) {
  auto residual = [&](std::size_t k, const Eigen::Vector3d& u, Eigen::Vector3d* grad) {
    const auto& o = problem.observations[k];
    const Eigen::Vector3d v = u - state.trackers_mm[static_cast<std::size_t>(o.tracker)];
    const double rho = v.norm();
    if (grad) *grad = v / rho;
    return 1e3 * (rho - state.offsets_mm[static_cast<std::size_t>(o.segment)] - o.d_mm);
  };
  // Sum of squared residuals (µm²) of the point re-estimated without the readings in `out`.
  auto ssr_without = [&](const std::vector<std::size_t>& out) {
    auto kept = [&](std::size_t k) { return std::find(out.begin(), out.end(), k) == out.end(); };
    Eigen::Vector3d u = state.points_mm[static_cast<std::size_t>(point)];
    for (int it = 0; it < 20; ++it) {
      Eigen::Matrix3d N = Eigen::Matrix3d::Zero();
      Eigen::Vector3d g = Eigen::Vector3d::Zero(), n;
      for (std::size_t k : ks) {
        if (!kept(k)) continue;
        const double r = 1e-3 * residual(k, u, &n);
        N += n * n.transpose();
        g += n * r;
      }
      const Eigen::Vector3d step = -N.ldlt().solve(g);
      if (!step.allFinite()) return std::numeric_limits<double>::infinity();
      u += step;
      if (step.norm() < 1e-10) break;
    }
    double ssr = 0;
    for (std::size_t k : ks) {
      if (kept(k)) ssr += std::pow(residual(k, u, nullptr), 2);
    }
    return ssr;
  };
  // Omissions of one reading: the best one when it leaves the rest consistent (should a second
  // one do so too, the next round tests what is left). Otherwise, with ≥ 6 readings, pairs: one
  // consistent pair is rejected; two different ones mean the readings cannot tell which are
  // wrong (two gross errors on 6 readings can cancel in 4 of them), and all are returned.
  const double n = static_cast<double>(ks.size());
  std::vector<std::size_t> best;
  double best_ssr = std::numeric_limits<double>::infinity();
  for (std::size_t k : ks) {
    const double ssr = ssr_without({k});
    if (ssr < best_ssr) {
      best_ssr = ssr;
      best = {k};
    }
  }
  if (ks.size() < 6 || best_ssr <= (n - 4) * tau_um * tau_um) return best;
  int consistent = 0;
  std::vector<std::size_t> pair;
  double pair_ssr = std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < ks.size(); ++a) {
    for (std::size_t b = a + 1; b < ks.size(); ++b) {
      const double ssr = ssr_without({ks[a], ks[b]});
      consistent += ssr <= (n - 5) * tau_um * tau_um;
      if (ssr < pair_ssr) {
        pair_ssr = ssr;
        pair = {ks[a], ks[b]};
      }
    }
  }
  if (consistent == 1) return pair;
  if (consistent > 1) return ks;
  return best;  // nothing consistent: the best single omission; the next round goes on
}

}  // namespace

Screening Screen(const SelfCalProblem& problem, const SelfCalState& state,
                 const SelfCalOptions& options) {
  Screening sc;
  sc.r = problem.ResidualsUm(state);
  std::vector<char> testable;
  sc.z = StandardisedResiduals(problem, state, sc.r, &testable);
  std::vector<double> tested;
  for (std::size_t k = 0; k < sc.z.size(); ++k) {
    if (testable[k]) tested.push_back(sc.z[k]);
  }
  const double sigma_rob = 1.4826 * MedianAbs(tested);
  sc.tau = std::max(options.outlier_k * sigma_rob, options.outlier_floor_um);
  return sc;
}

// One round of rejection on the current solution; true when a reading was taken out.
bool RejectRound(SelfCalProblem& problem, const TrackerReadings& readings,
                 const SelfCalOptions& options, const SelfCalState& state, bool last_was_plain,
                 SelfCalResult& res) {
  const int m = readings.NumPoints();
  bool changed = false;
  const Screening sc = Screen(problem, state, options);
  const std::vector<double>& r = sc.r;
  const std::vector<double>& z = sc.z;
  // The robust pass is stopped early: from it, only clearly gross readings are taken out;
  // the finer cuts are made on converged least-squares solutions.
  const double factor = last_was_plain ? 1.0 : 3.0;
  const double tau_base = sc.tau;
  const double tau = factor * tau_base;
  std::map<int, std::vector<std::size_t>> flagged;  // point → readings over threshold
  for (std::size_t k = 0; k < r.size(); ++k) {
    if (problem.active[k] && std::abs(z[k]) > tau) {
      flagged[problem.observations[k].point].push_back(k);
    }
  }
  // The active readings of each point (in observation order).
  std::vector<std::vector<std::size_t>> of_point(static_cast<std::size_t>(m));
  for (std::size_t k = 0; k < r.size(); ++k) {
    if (problem.active[k])
      of_point[static_cast<std::size_t>(problem.observations[k].point)].push_back(k);
  }
  for (const auto& [point, ks] : flagged) {
    const std::vector<std::size_t>& readings_of = of_point[static_cast<std::size_t>(point)];
    std::vector<std::size_t> drop;
    if (readings_of.size() >= 5) {
      // The point is re-estimated for each omission: the unscaled threshold applies.
      drop = LeastConsistentReadings(problem, state, point, readings_of, tau_base);
    } else {
      drop = readings_of;
    }
    for (std::size_t k : drop) {
      problem.active[k] = 0;
      const auto& o = problem.observations[k];
      res.rejected.push_back({o.point, readings.point_ids[static_cast<std::size_t>(o.point)],
                              o.tracker, r[k], z[k], "residual"});
    }
    changed = true;
  }
  return changed;
}

}  // namespace km::tracker::selfcal_stages
