#include "analysis/tracker/tracker_selfcal.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

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
// add little). Readings without redundancy (1 − h ≈ 0) get 0: they cannot be tested.
std::vector<double> StandardisedResiduals(const SelfCalProblem& problem, const SelfCalState& state,
                                          const std::vector<double>& r) {
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
  for (std::size_t k = 0; k < r.size(); ++k) {
    if (!problem.active[k]) continue;
    const double h =
        dir[k].dot(Ainv[static_cast<std::size_t>(problem.observations[k].point)] * dir[k]);
    z[k] = 1.0 - h > 1e-3 ? r[k] / std::sqrt(1.0 - h) : 0.0;
  }
  return z;
}

// Points whose volumetric error departs from a smooth field: per component, a full polynomial
// in the normalised commanded coordinates (cubic with ≥ 80 points, quadratic with ≥ 40, else no
// test) is fitted to the errors after the best rigid fit; the departures are divided by the
// point's own precision (√ diag A⁻¹, A = Σ n nᵀ over its readings, rotated to the commanded
// frame) and compared with k robust σ. Two passes, so that the outliers do not bend the fit.
std::vector<int> SpatialOutliers(const SelfCalProblem& problem, const SelfCalState& state,
                                 const std::vector<Eigen::Vector3d>& commanded, double k) {
  const auto use = problem.PointsInUse();
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < use.size(); ++i) {
    if (use[i]) idx.push_back(i);
  }
  const int degree = idx.size() >= 80 ? 3 : (idx.size() >= 40 ? 2 : 0);
  if (degree == 0) return {};
  const RigidTransform T = FitRigid(state.points_mm, commanded, &use);
  // Point precision in the commanded frame.
  const auto m = static_cast<std::size_t>(problem.num_points);
  std::vector<Eigen::Matrix3d> A(m, Eigen::Matrix3d::Zero());
  for (std::size_t q = 0; q < problem.observations.size(); ++q) {
    if (!problem.active[q]) continue;
    const auto& o = problem.observations[q];
    const Eigen::Vector3d n = (state.points_mm[static_cast<std::size_t>(o.point)] -
                               state.trackers_mm[static_cast<std::size_t>(o.tracker)])
                                  .normalized();
    A[static_cast<std::size_t>(o.point)] += n * n.transpose();
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t i : idx) {
    lo = lo.cwiseMin(commanded[i]);
    hi = hi.cwiseMax(commanded[i]);
  }
  const Eigen::Vector3d mid = 0.5 * (lo + hi);
  const Eigen::Vector3d half = (0.5 * (hi - lo)).cwiseMax(1e-9);
  std::vector<std::array<int, 3>> powers;
  for (int a = 0; a <= degree; ++a) {
    for (int b = 0; a + b <= degree; ++b) {
      for (int c = 0; a + b + c <= degree; ++c) powers.push_back({a, b, c});
    }
  }
  const long nb = static_cast<long>(powers.size());
  const long np = static_cast<long>(idx.size());
  Eigen::MatrixXd X(np, nb);
  Eigen::MatrixXd E(np, 3);
  Eigen::MatrixXd W(np, 3);  // precision scale per component
  for (long r = 0; r < np; ++r) {
    const std::size_t i = idx[static_cast<std::size_t>(r)];
    const Eigen::Vector3d t = (commanded[i] - mid).cwiseQuotient(half);
    for (long c = 0; c < nb; ++c) {
      const auto& p = powers[static_cast<std::size_t>(c)];
      X(r, c) = std::pow(t.x(), p[0]) * std::pow(t.y(), p[1]) * std::pow(t.z(), p[2]);
    }
    E.row(r) = (1e3 * (T.Apply(state.points_mm[i]) - commanded[i])).transpose();
    Eigen::FullPivLU<Eigen::Matrix3d> lu(A[i]);
    const Eigen::Matrix3d C =
        lu.isInvertible() ? Eigen::Matrix3d(T.rotation * lu.inverse() * T.rotation.transpose())
                          : Eigen::Matrix3d::Identity();
    W.row(r) = C.diagonal().cwiseMax(1e-12).cwiseSqrt().transpose();
  }
  std::vector<char> keep(static_cast<std::size_t>(np), 1);
  std::vector<int> out;
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<long> rows;
    for (long r = 0; r < np; ++r) {
      if (keep[static_cast<std::size_t>(r)]) rows.push_back(r);
    }
    if (static_cast<long>(rows.size()) < 2 * nb) return {};
    Eigen::MatrixXd Xk(static_cast<long>(rows.size()), nb), Ek(static_cast<long>(rows.size()), 3);
    for (std::size_t q = 0; q < rows.size(); ++q) {
      Xk.row(static_cast<long>(q)) = X.row(rows[q]);
      Ek.row(static_cast<long>(q)) = E.row(rows[q]);
    }
    const Eigen::MatrixXd coef = Xk.colPivHouseholderQr().solve(Ek);
    const Eigen::MatrixXd Z = (E - X * coef).cwiseQuotient(W);
    std::vector<double> all(Z.data(), Z.data() + Z.size());
    const double sigma = 1.4826 * MedianAbs(all);
    out.clear();
    for (long r = 0; r < np; ++r) {
      const bool bad = Z.row(r).cwiseAbs().maxCoeff() > k * std::max(sigma, 1e-9);
      keep[static_cast<std::size_t>(r)] = !bad;
      if (bad) out.push_back(static_cast<int>(idx[static_cast<std::size_t>(r)]));
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
      const auto z = StandardisedResiduals(problem, state, r);
      const double sigma_rob = 1.4826 * MedianAbs(z);
      // The robust pass is stopped early: from it, only clearly gross readings are taken out;
      // the finer cuts are made on converged least-squares solutions.
      const double factor = last_was_plain ? 1.0 : 3.0;
      const double tau = factor * std::max(options.outlier_k * sigma_rob, options.outlier_floor_um);
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
          drop.push_back(*std::max_element(ks.begin(), ks.end(), [&](std::size_t a, std::size_t b) {
            return std::abs(z[a]) < std::abs(z[b]);
          }));
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
      if (!changed && last_was_plain && options.spatial_check) {
        for (int point :
             SpatialOutliers(problem, state, readings.commanded_mm, options.outlier_k)) {
          for (std::size_t k = 0; k < r.size(); ++k) {
            const auto& o = problem.observations[k];
            if (!problem.active[k] || o.point != point) continue;
            problem.active[k] = 0;
            res.rejected.push_back({o.point, readings.point_ids[static_cast<std::size_t>(o.point)],
                                    o.tracker, r[k], z[k], "spatial"});
            changed = true;
          }
        }
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
  return res;
}

}  // namespace km::tracker
