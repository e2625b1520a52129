#include "analysis/tracker/tracker_selfcal.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>

#include "analysis/core/errors.h"
#include "analysis/tracker/selfcal_ceres.h"

namespace km::tracker {

void SelfCalOptions::Check() const {
  auto bad = [](const char* f, const char* why) { throw InvalidInput("", 0, f, why); };
  if (!(outlier_k > 1.0)) bad("outlier_k", "must be > 1");
  if (!(outlier_floor_um >= 0.0)) bad("outlier_floor_um", "must be ≥ 0");
  if (max_rejection_rounds < 0) bad("max_rejection_rounds", "must be ≥ 0");
  if (!(robust_scale_um >= 0.0)) bad("robust_scale_um", "must be ≥ 0");
  if (max_iterations < 1) bad("max_iterations", "must be ≥ 1");
  if (!(max_condition_number > 1.0)) bad("max_condition_number", "must be > 1");
  if (!(prior_sigma_um > 0.0)) bad("prior_sigma_um", "must be > 0");
  if (num_threads < 1) bad("num_threads", "must be ≥ 1");
}

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

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

// Residuals divided by √(1 − h), h the leverage of the reading within its point block
// (h = nᵀ A⁻¹ n, A = Σ n nᵀ over the point's active readings; the shared tracker parameters
// add little). Readings without redundancy (1 − h ≈ 0) get 0: they cannot be tested, and are
// marked in `testable` (when given) so that they do not enter the robust σ. (Far trackers can
// leave half the readings of every point without redundancy: counting their zeros would shrink
// the σ and reject clean readings.)
std::vector<double> StandardisedResiduals(const SelfCalProblem& problem, const SelfCalState& state,
                                          const std::vector<double>& r,
                                          std::vector<char>* testable = nullptr) {
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

// Of a point's active readings (≥ 5), those the other trackers' view of the point disagrees
// with: the point is re-estimated from all its readings but one (trackers and dead paths held),
// for each reading in turn, and the reading whose omission leaves the others most consistent
// (sum of squared residuals within (redundancy)·tau²) is returned; pairs as below. The largest
// standardised residual alone may point at a good reading when a robust pass has settled the
// point in the wrong place.
std::vector<std::size_t> LeastConsistentReadings(const SelfCalProblem& problem,
                                                 const SelfCalState& state, int point,
                                                 double tau_um) {
  std::vector<std::size_t> ks;
  for (std::size_t k = 0; k < problem.observations.size(); ++k) {
    if (problem.active[k] && problem.observations[k].point == point) ks.push_back(k);
  }
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

// The K nearest points (commanded positions) of each point in `idx`, among `idx`: the points
// are binned in cubic cells of about one point each, and rings of cells around a point's own
// cell are searched until no farther cell can hold a nearer point.
std::vector<std::vector<std::size_t>> NearestNeighbours(const std::vector<Eigen::Vector3d>& c,
                                                        const std::vector<std::size_t>& idx,
                                                        std::size_t K) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t i : idx) {
    lo = lo.cwiseMin(c[i]);
    hi = hi.cwiseMax(c[i]);
  }
  const double extent = std::max((hi - lo).maxCoeff(), 1e-9);
  double cell = extent / std::max(1.0, std::ceil(std::cbrt(static_cast<double>(idx.size()))));
  Eigen::Vector3i dims;
  for (;;) {
    for (int a = 0; a < 3; ++a) dims(a) = static_cast<int>((hi(a) - lo(a)) / cell) + 1;
    if (static_cast<double>(dims.prod()) <= 8.0 * static_cast<double>(idx.size()) + 64) break;
    cell *= 1.5;  // a few far-off points: fewer, larger cells
  }
  auto cell_of = [&](const Eigen::Vector3d& p) {
    Eigen::Vector3i q;
    for (int a = 0; a < 3; ++a) {
      q(a) = std::clamp(static_cast<int>((p(a) - lo(a)) / cell), 0, dims(a) - 1);
    }
    return q;
  };
  auto flat = [&](const Eigen::Vector3i& q) {
    return (static_cast<std::size_t>(q.z()) * static_cast<std::size_t>(dims.y()) +
            static_cast<std::size_t>(q.y())) *
               static_cast<std::size_t>(dims.x()) +
           static_cast<std::size_t>(q.x());
  };
  std::vector<std::vector<std::size_t>> bins(static_cast<std::size_t>(dims.prod()));
  for (std::size_t q = 0; q < idx.size(); ++q) bins[flat(cell_of(c[idx[q]]))].push_back(q);
  std::vector<std::vector<std::size_t>> out(idx.size());
  std::vector<std::pair<double, std::size_t>> best;  // max-heap of (squared distance, position)
  const int max_ring = dims.maxCoeff();
  for (std::size_t q = 0; q < idx.size(); ++q) {
    const Eigen::Vector3d& p = c[idx[q]];
    const Eigen::Vector3i home = cell_of(p);
    best.clear();
    for (int ring = 0; ring <= max_ring; ++ring) {
      for (int dz = -ring; dz <= ring; ++dz) {
        for (int dy = -ring; dy <= ring; ++dy) {
          for (int dx = -ring; dx <= ring; ++dx) {
            if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != ring) continue;
            const Eigen::Vector3i nb = home + Eigen::Vector3i(dx, dy, dz);
            if ((nb.array() < 0).any() || (nb.array() >= dims.array()).any()) continue;
            for (std::size_t other : bins[flat(nb)]) {
              if (other == q) continue;
              const double d2 = (c[idx[other]] - p).squaredNorm();
              if (best.size() < K) {
                best.emplace_back(d2, other);
                std::push_heap(best.begin(), best.end());
              } else if (d2 < best.front().first) {
                std::pop_heap(best.begin(), best.end());
                best.back() = {d2, other};
                std::push_heap(best.begin(), best.end());
              }
            }
          }
        }
      }
      // Cells of the next ring are at least ring·cell away.
      const double reach = ring * cell;
      if (best.size() == K && best.front().first <= reach * reach) break;
    }
    for (const auto& [d2, other] : best) out[q].push_back(other);
  }
  return out;
}

// Spatial consistency of the volumetric error map, a WARNING only: nothing is discarded, because
// a machine's error field need not be smooth (ball-screw and guide waviness, steps, local wear)
// and the readings are the only evidence against a reading. A point is named when its error,
// after a quadratic trend is removed, departs from the median of its nearest neighbours by more
// than k times sqrt(s² + σ²), s the map's local scatter of that component (90th percentile of
// the differences between neighbouring points) and σ the point's own precision. With 4 trackers a
// point has a single redundant reading, in which two gross errors on it can cancel: the readings
// fit a displaced point, and only the map shows it.
struct SpatialDeparture {
  std::size_t row = 0;
  Eigen::Vector3d departure_um = Eigen::Vector3d::Zero();
  double sigmas = 0.0;
  int neighbours = 0;
};
std::vector<SpatialDeparture> SpatialDepartures(const std::vector<Eigen::Vector3d>& commanded,
                                                const std::vector<Eigen::Vector3d>& error_um,
                                                const std::vector<Eigen::Vector3d>& sigma_um,
                                                const std::vector<char>& use, double k) {
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (use[i] && error_um[i].allFinite()) idx.push_back(i);
  }
  const long np = static_cast<long>(idx.size());
  if (np < 20) return {};
  // Quadratic trend (linear below 40 points) in normalised coordinates, per component.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t i : idx) {
    lo = lo.cwiseMin(commanded[i]);
    hi = hi.cwiseMax(commanded[i]);
  }
  const Eigen::Vector3d mid = 0.5 * (lo + hi);
  const Eigen::Vector3d half = (0.5 * (hi - lo)).cwiseMax(1e-9);
  const int degree = np >= 40 ? 2 : 1;
  std::vector<std::array<int, 3>> powers;
  for (int a = 0; a <= degree; ++a) {
    for (int b = 0; a + b <= degree; ++b) {
      for (int c = 0; a + b + c <= degree; ++c) powers.push_back({a, b, c});
    }
  }
  Eigen::MatrixXd X(np, static_cast<long>(powers.size()));
  Eigen::MatrixXd E(np, 3);
  for (long r = 0; r < np; ++r) {
    const std::size_t i = idx[static_cast<std::size_t>(r)];
    const Eigen::Vector3d t = (commanded[i] - mid).cwiseQuotient(half);
    for (std::size_t q = 0; q < powers.size(); ++q) {
      const auto& p = powers[q];
      X(r, static_cast<long>(q)) =
          std::pow(t.x(), p[0]) * std::pow(t.y(), p[1]) * std::pow(t.z(), p[2]);
    }
    E.row(r) = error_um[i].transpose();
  }
  const Eigen::MatrixXd F = E - X * X.colPivHouseholderQr().solve(E);
  // Departure from the median of the nearest neighbours.
  const std::size_t K = 6;
  const auto nb = NearestNeighbours(commanded, idx, K);
  Eigen::MatrixXd D(np, 3);
  std::vector<double> v;
  for (long r = 0; r < np; ++r) {
    for (int comp = 0; comp < 3; ++comp) {
      v.clear();
      for (std::size_t q : nb[static_cast<std::size_t>(r)])
        v.push_back(F(static_cast<long>(q), comp));
      std::sort(v.begin(), v.end());
      const double med =
          v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
      D(r, comp) = F(r, comp) - med;
    }
  }
  // The map's local scatter: 90th percentile of the differences between neighbouring points
  // (an upper quantile, as a wavy field along one axis leaves most neighbours equal).
  Eigen::Vector3d scale;
  for (int comp = 0; comp < 3; ++comp) {
    std::vector<double> diff;
    for (long r = 0; r < np; ++r) {
      for (std::size_t q : nb[static_cast<std::size_t>(r)]) {
        diff.push_back(std::abs(F(r, comp) - F(static_cast<long>(q), comp)));
      }
    }
    const auto at = diff.begin() + static_cast<long>(0.9 * static_cast<double>(diff.size() - 1));
    std::nth_element(diff.begin(), at, diff.end());
    scale(comp) = *at;
  }
  std::vector<SpatialDeparture> out;
  for (long r = 0; r < np; ++r) {
    const std::size_t i = idx[static_cast<std::size_t>(r)];
    double z = 0;
    for (int comp = 0; comp < 3; ++comp) {
      const double s = sigma_um[i].allFinite() ? sigma_um[i](comp) : 0.0;
      const double denom = std::sqrt(scale(comp) * scale(comp) + s * s);
      z = std::max(z, std::abs(D(r, comp)) / std::max(denom, 1e-3));  // nm: not worth a word
    }
    if (z > k) {
      out.push_back(
          {i, D.row(r).transpose(), z, static_cast<int>(nb[static_cast<std::size_t>(r)].size())});
    }
  }
  return out;
}

double PointSpreadMm(const SelfCalState& state, const SelfCalProblem& problem) {
  const auto use = problem.PointsInUse();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  double cnt = 0;
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (use[i]) {
      mean += state.points_mm[i];
      cnt += 1;
    }
  }
  if (cnt == 0) return 0.0;
  mean /= cnt;
  double s = 0;
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (use[i]) s += (state.points_mm[i] - mean).squaredNorm();
  }
  return std::sqrt(s / cnt);
}

}  // namespace

SelfCalResult SelfCalibrate(const TrackerReadings& readings, const SelfCalOptions& options) {
  options.Check();
  const int m = readings.NumPoints();
  const int n = readings.NumTrackers();
  if (static_cast<int>(readings.point_ids.size()) != m) {
    throw InvalidInput("", 0, "point", "one point id per commanded point needed");
  }
  for (const auto& g : readings.guesses) {
    if (g.tracker < 0 || g.tracker >= n) {
      throw InvalidInput("", 0, "tracker_guess_mm",
                         "tracker " + std::to_string(g.tracker + 1) + " does not exist");
    }
    if (!g.position_mm.allFinite() || g.position_mm.cwiseAbs().maxCoeff() > kMaxTrackerGuessMm) {
      std::ostringstream os;
      os << "tracker " << g.tracker + 1 << ": the guessed position (" << g.position_mm.x() << ", "
         << g.position_mm.y() << ", " << g.position_mm.z()
         << ") mm is farther than 100 m from the machine origin";
      throw InvalidInput("", 0, "tracker_guess_mm", os.str());
    }
  }
  SelfCalProblem problem = SelfCalProblem::FromReadings(readings);
  problem.CheckCounting();

  SelfCalResult res;
  res.mode = readings.mode;
  // 1. Initialisation in the machine frame, one tracker at a time.
  std::vector<Eigen::Vector3d> U0(static_cast<std::size_t>(n));
  SelfCalState state;
  state.offsets_mm.assign(static_cast<std::size_t>(problem.NumSegments()), 0.0);
  for (int j = 0; j < n; ++j) {
    const Eigen::Vector3d* guess = nullptr;
    for (const auto& g : readings.guesses) {
      if (g.tracker == j) {
        guess = &g.position_mm;
        break;
      }
    }
    const TrackerInit init = InitialiseTracker(problem, readings, j, guess);
    U0[static_cast<std::size_t>(j)] = init.position_mm;
    res.initial_rms_um.push_back(init.rms_um);
    std::size_t local = 0;
    for (int s = 0; s < problem.NumSegments(); ++s) {
      if (problem.segment_tracker[static_cast<std::size_t>(s)] == j) {
        if (local >= init.offsets_mm.size()) {
          throw DidNotConverge("laser-tracker self-calibration: the initial fit of tracker " +
                               std::to_string(j + 1) + " gave no dead path for every segment");
        }
        state.offsets_mm[static_cast<std::size_t>(s)] = init.offsets_mm[local++];
      }
    }
  }
  // 2. Into the gauge frame.
  const RigidTransform T = GaugeTransform(U0);
  for (const auto& u : U0) state.trackers_mm.push_back(T.Apply(u));
  state.trackers_mm[0].setZero();
  state.trackers_mm[1].tail<2>().setZero();
  state.trackers_mm[2].z() = 0.0;
  for (const auto& c : readings.commanded_mm) state.points_mm.push_back(T.Apply(c));

  // 3. Robust pass, then rejection rounds with least-squares re-solves.
  CeresSolveOptions copt;
  copt.max_iterations = options.max_iterations;
  copt.num_threads = options.num_threads;
  copt.sparse_schur = options.sparse_schur;
  // Plain least squares from the initial values first (fast, close even with gross errors),
  // then the robust (Cauchy) pass from there.
  copt.cauchy_scale_um = 0.0;
  auto rep = SolveSelfCalCeres(problem, copt, state);
  res.iterations += rep.iterations;
  bool last_was_plain = true;
  copt.initial_trust_region_radius = 1e8;
  if (options.reject_outliers && options.robust_scale_um > 0) {
    // Only to expose the gross errors: a few iterations suffice, the rejection rounds re-solve.
    copt.cauchy_scale_um = options.robust_scale_um;
    copt.max_iterations = std::min(options.max_iterations, 10);
    rep = SolveSelfCalCeres(problem, copt, state);
    res.iterations += rep.iterations;
    last_was_plain = false;
    copt.cauchy_scale_um = 0.0;
    copt.max_iterations = options.max_iterations;
  }
  for (int round = 0; round <= options.max_rejection_rounds; ++round) {
    bool changed = false;
    if (options.reject_outliers && round < options.max_rejection_rounds) {
      const auto r = problem.ResidualsUm(state);
      std::vector<char> testable;
      const auto z = StandardisedResiduals(problem, state, r, &testable);
      std::vector<double> tested;
      for (std::size_t k = 0; k < z.size(); ++k) {
        if (testable[k]) tested.push_back(z[k]);
      }
      const double sigma_rob = 1.4826 * MedianAbs(tested);
      // The robust pass is stopped early: from it, only clearly gross readings are taken out;
      // the finer cuts are made on converged least-squares solutions.
      const double factor = last_was_plain ? 1.0 : 3.0;
      const double tau_base = std::max(options.outlier_k * sigma_rob, options.outlier_floor_um);
      const double tau = factor * tau_base;
      std::map<int, std::vector<std::size_t>> flagged;  // point → readings over threshold
      for (std::size_t k = 0; k < r.size(); ++k) {
        if (problem.active[k] && std::abs(z[k]) > tau) {
          flagged[problem.observations[k].point].push_back(k);
        }
      }
      std::vector<int> active_count(static_cast<std::size_t>(m), 0);
      for (std::size_t k = 0; k < r.size(); ++k) {
        if (problem.active[k])
          ++active_count[static_cast<std::size_t>(problem.observations[k].point)];
      }
      for (const auto& [point, ks] : flagged) {
        std::vector<std::size_t> drop;
        if (active_count[static_cast<std::size_t>(point)] >= 5) {
          // The point is re-estimated for each omission: the unscaled threshold applies.
          drop = LeastConsistentReadings(problem, state, point, tau_base);
        } else {
          for (std::size_t k = 0; k < r.size(); ++k) {
            if (problem.active[k] && problem.observations[k].point == point) drop.push_back(k);
          }
        }
        for (std::size_t k : drop) {
          problem.active[k] = 0;
          const auto& o = problem.observations[k];
          res.rejected.push_back({o.point, readings.point_ids[static_cast<std::size_t>(o.point)],
                                  o.tracker, r[k], z[k], "residual"});
        }
        changed = true;
      }
    }
    if (!changed && last_was_plain) break;
    if (changed) problem.CheckCounting();
    rep = SolveSelfCalCeres(problem, copt, state);
    res.iterations += rep.iterations;
    res.rounds = round + 1;
    last_was_plain = true;
  }
  if (!std::isfinite(rep.final_cost)) {
    throw DidNotConverge("laser-tracker self-calibration: " + rep.message);
  }
  // The answer is the least-squares optimum of the readings in use: a solve stopped by its
  // iteration limit (far trackers make the problem ill-conditioned) is continued.
  for (int extra = 0; extra < 4 && !rep.converged; ++extra) {
    rep = SolveSelfCalCeres(problem, copt, state);
    res.iterations += rep.iterations;
  }
  if (!rep.converged) {
    res.warnings.push_back(
        "the least-squares solve stopped after " + std::to_string(res.iterations) +
        " iterations without meeting its convergence tolerance: the result may be short of the "
        "optimum (" +
        rep.message + ")");
  }
  // 4. Gauge sign: z of tracker 4 > 0 (mirror image otherwise).
  if (n >= 4 && state.trackers_mm[3].z() < 0) {
    for (auto& u : state.trackers_mm) u.z() = -u.z();
    for (auto& u : state.points_mm) u.z() = -u.z();
  }
  // 5. Residuals, σ, covariance and observability of the solution.
  const auto r = problem.ResidualsUm(state);
  double ssr = 0;
  for (double x : r) {
    if (std::isfinite(x)) ssr += x * x;
  }
  res.readings_used = problem.NumActive();
  res.unknowns = problem.NumUnknowns();
  res.residual_rms_um = std::sqrt(ssr / std::max<std::size_t>(res.readings_used, 1));
  res.sigma_um = res.readings_used > res.unknowns
                     ? std::sqrt(ssr / static_cast<double>(res.readings_used - res.unknowns))
                     : options.prior_sigma_um;
  const SelfCalCovariance cov = ComputeCovariance(problem, state, res.sigma_um);
  res.condition_number = cov.condition_number;
  const auto mm = static_cast<std::size_t>(m);
  const bool complete = cov.point_block_um2.size() == mm && cov.coupling.size() == mm &&
                        cov.point_free_um2.size() == mm && cov.point_gauge_um2.size() == mm &&
                        cov.tracker_um2.size() == static_cast<std::size_t>(n);
  if (cov.rank_deficiency > 0 || !complete ||
      !(cov.condition_number <= options.max_condition_number)) {
    std::ostringstream os;
    os << "laser-tracker self-calibration is not observable: the Jacobian of the gauge-fixed "
          "problem is ";
    if (cov.rank_deficiency > 0) {
      os << "rank-deficient (" << cov.rank_deficiency << " direction"
         << (cov.rank_deficiency > 1 ? "s" : "") << " of the tracker/dead-path parameters "
         << "undetermined)";
    } else {
      os << "ill-conditioned: condition number " << cov.condition_number << " > "
         << options.max_condition_number;
    }
    // The usual cause: all trackers in one plane (e.g. all on the table, as in [Tracker paper]).
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& u : state.trackers_mm) mean += u;
    mean /= static_cast<double>(n);
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (const auto& u : state.trackers_mm) scatter += (u - mean) * (u - mean).transpose();
    const Eigen::Vector3d ev =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();
    const double out_of_plane_mm = std::sqrt(std::max(ev(0), 0.0) / n);
    os << "; the trackers lie within " << out_of_plane_mm
       << " mm (rms) of one plane and the points span " << PointSpreadMm(state, problem)
       << " mm (rms about their centroid)";
    if (out_of_plane_mm < 0.05 * std::sqrt(std::max(ev(2), 0.0) / n)) {
      os << ": trackers (nearly) coplanar make the self-calibration singular; raise or lower "
            "at least one tracker well out of the plane of the others";
    }
    throw NotObservable(os.str());
  }
  // Weak or ambiguous geometry that still solves.
  {
    const auto spread = [](const std::vector<Eigen::Vector3d>& v, const std::vector<char>* use) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      double cnt = 0;
      for (std::size_t i = 0; i < v.size(); ++i) {
        if (use && !(*use)[i]) continue;
        mean += v[i];
        cnt += 1;
      }
      mean /= std::max(cnt, 1.0);
      Eigen::Matrix3d sc = Eigen::Matrix3d::Zero();
      for (std::size_t i = 0; i < v.size(); ++i) {
        if (use && !(*use)[i]) continue;
        sc += (v[i] - mean) * (v[i] - mean).transpose();
      }
      const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(sc).eigenvalues();
      return std::sqrt(std::max(ev(0), 0.0) / std::max(ev(2), 1e-300));
    };
    const auto use_points = problem.PointsInUse();
    if (spread(state.points_mm, &use_points) < 1e-3) {
      res.warnings.push_back(
          "the points lie in one plane: each tracker position is known only up to its mirror "
          "image through that plane (the points and their volumetric errors are not affected)");
    }
    if (spread(state.trackers_mm, nullptr) < 0.05) {
      res.warnings.push_back(
          "the trackers are nearly coplanar: the self-calibration is weak (see "
          "position_uncertainty_um); place at least one tracker well out of their plane");
    }
  }
  // 6. Results in the gauge frame and, after the best fit, in the commanded frame.
  const std::vector<char> use = problem.PointsInUse();
  res.point_valid = use;
  res.trackers_mm = state.trackers_mm;
  for (const auto& C : cov.tracker_um2) {
    res.tracker_uncertainty_um.push_back(C.diagonal().cwiseMax(0.0).cwiseSqrt());
  }
  res.dead_path_mm = state.offsets_mm;
  res.dead_path_tracker = problem.segment_tracker;
  res.gauge_to_commanded = FitRigid(state.points_mm, readings.commanded_mm, &use);
  const Eigen::Matrix3d& R = res.gauge_to_commanded.rotation;
  const Eigen::Vector3d nan3 = Eigen::Vector3d::Constant(kNaN);
  res.error_covariance.shared = cov.shared_um2;
  for (int i = 0; i < m; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    res.error_covariance.point_um2.push_back(R * cov.point_block_um2[ui] * R.transpose());
    res.error_covariance.coupling.push_back(R * cov.coupling[ui]);
  }
  for (int i = 0; i < m; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    if (!use[ui]) {
      res.points_mm.push_back(nan3);
      res.volumetric_error_um.push_back(nan3);
      res.position_uncertainty_um.push_back(nan3);
      res.gauge_uncertainty_um.push_back(nan3);
      continue;
    }
    res.points_mm.push_back(state.points_mm[ui]);
    res.volumetric_error_um.push_back(
        1e3 * (res.gauge_to_commanded.Apply(state.points_mm[ui]) - readings.commanded_mm[ui]));
    const Eigen::Matrix3d Cf = R * cov.point_free_um2[ui] * R.transpose();
    res.position_uncertainty_um.push_back(Cf.diagonal().cwiseMax(0.0).cwiseSqrt());
    res.gauge_uncertainty_um.push_back(
        cov.point_gauge_um2[ui].diagonal().cwiseMax(0.0).cwiseSqrt());
  }
  // 7. Spatial consistency of the map: a warning naming the points; nothing is discarded.
  if (options.spatial_check) {
    const auto rr = problem.ResidualsUm(state);
    const auto zz = StandardisedResiduals(problem, state, rr);
    std::vector<double> worst_z(mm, 0.0);
    for (std::size_t k = 0; k < zz.size(); ++k) {
      if (!problem.active[k]) continue;
      auto& w = worst_z[static_cast<std::size_t>(problem.observations[k].point)];
      w = std::max(w, std::abs(zz[k]));
    }
    std::vector<int> active_count(mm, 0);
    for (std::size_t k = 0; k < problem.observations.size(); ++k) {
      if (problem.active[k])
        ++active_count[static_cast<std::size_t>(problem.observations[k].point)];
    }
    std::ostringstream names;
    for (const auto& d : SpatialDepartures(readings.commanded_mm, res.volumetric_error_um,
                                           res.position_uncertainty_um, use, options.outlier_k)) {
      SpatialOutlier o;
      o.row = static_cast<int>(d.row);
      o.point_id = readings.point_ids[d.row];
      o.departure_um = d.departure_um;
      o.departure_sigmas = d.sigmas;
      o.largest_standardised_um = worst_z[d.row];
      std::ostringstream why;
      why.precision(3);
      why << "its volumetric error departs from the median of its " << d.neighbours
          << " nearest neighbours by " << d.departure_um.norm() << " um (" << d.sigmas
          << " times the map's local scatter and its own precision), while its "
          << active_count[d.row] << " readings fit (largest standardised residual "
          << worst_z[d.row] << " um): kept, as the readings show no gross error";
      if (active_count[d.row] <= 4) {
        why << " (with 4 readings a point has one redundant reading, so two gross errors on it "
               "can cancel)";
      }
      why << "; check the point or measure it again";
      o.reason = why.str();
      if (!res.spatial_outliers.empty()) names << ", ";
      names << o.point_id;
      res.spatial_outliers.push_back(std::move(o));
    }
    if (!res.spatial_outliers.empty()) {
      res.warnings.push_back(
          "spatial check (a warning only, nothing was discarded): point" +
          std::string(res.spatial_outliers.size() > 1 ? "s " : " ") + names.str() + " depart" +
          (res.spatial_outliers.size() > 1 ? "" : "s") +
          " from their neighbours' volumetric errors far beyond the map's local scatter; see "
          "spatial_outliers");
    }
  }
  return res;
}

}  // namespace km::tracker
