// The stages of the laser-tracker self-calibration ([Tracker paper] §4), each a named function
// that SelfCalibrate (tracker_selfcal.cpp) runs in turn.
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
#include "analysis/tracker/tracker_selfcal_stages.h"

namespace km::tracker::selfcal_stages {
namespace {

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

// The NotObservable error of a rank-deficient or ill-conditioned solution, naming the usual
// cause: all trackers in one plane (e.g. all on the table, as in [Tracker paper]).
[[noreturn]] void ThrowNotObservable(const SelfCalProblem& problem, const SelfCalState& state,
                                     const SelfCalCovariance& cov, const SelfCalOptions& options) {
  const int n = static_cast<int>(state.trackers_mm.size());
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
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& u : state.trackers_mm) mean += u;
  mean /= static_cast<double>(n);
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& u : state.trackers_mm) scatter += (u - mean) * (u - mean).transpose();
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();
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

// Trackers within 1 mm per metre of one plane (the initial positions): refused. At coplanar
// trackers the Jacobian of eq. (1) loses rank (the trackers can tilt out of their plane, the
// points following, to first order), and a solve drifts along that valley, far from the truth,
// to a meaningless optimum. Initial positions of coplanar trackers lie within ~1e-5 of a plane;
// 10 mm out of the plane of trackers a metre apart (1e-2) solves.
constexpr double kCoplanarTrackers = 1e-3;
void RefuseCoplanarTrackers(const std::vector<Eigen::Vector3d>& U) {
  const auto n = static_cast<double>(U.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& u : U) mean += u;
  mean /= n;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& u : U) scatter += (u - mean) * (u - mean).transpose();
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();
  const double out_mm = std::sqrt(std::max(ev(0), 0.0) / n);
  const double in_mm = std::sqrt(std::max(ev(2), 0.0) / n);
  if (!(out_mm < kCoplanarTrackers * in_mm)) return;
  std::ostringstream os;
  os << "laser-tracker self-calibration is not observable: the trackers lie within " << out_mm
     << " mm (rms) of one plane while they spread " << in_mm
     << " mm (rms) in it: trackers (nearly) coplanar make the self-calibration singular "
        "([Tracker paper] eq. 1 cannot fix their tilt out of the plane); raise or lower at least "
        "one tracker well out of the plane of the others";
  throw NotObservable(os.str());
}

// Warnings for weak or ambiguous geometry that still solves.
void WarnWeakGeometry(const SelfCalProblem& problem, const SelfCalState& state,
                      SelfCalResult& res) {
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

}  // namespace

void CheckReadings(const TrackerReadings& readings) {
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
}

SelfCalState Initialise(const SelfCalProblem& problem, const TrackerReadings& readings,
                        SelfCalResult& res) {
  const int n = readings.NumTrackers();
  std::vector<Eigen::Vector3d> U0(static_cast<std::size_t>(n));
  SelfCalState state;
  state.offsets_mm.assign(static_cast<std::size_t>(problem.NumSegments()), 0.0);
  res.warnings.insert(res.warnings.end(), problem.notes.begin(), problem.notes.end());
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
      if (problem.segments[static_cast<std::size_t>(s)].tracker == j) {
        if (local >= init.offsets_mm.size()) {
          throw DidNotConverge("laser-tracker self-calibration: the initial fit of tracker " +
                               std::to_string(j + 1) + " gave no dead path for every segment");
        }
        state.offsets_mm[static_cast<std::size_t>(s)] = init.offsets_mm[local++];
      }
    }
  }
  RefuseCoplanarTrackers(U0);
  // 2. Into the gauge frame.
  const RigidTransform T = GaugeTransform(U0);
  for (const auto& u : U0) state.trackers_mm.push_back(T.Apply(u));
  state.trackers_mm[0].setZero();
  state.trackers_mm[1].tail<2>().setZero();
  state.trackers_mm[2].z() = 0.0;
  for (const auto& c : readings.commanded_mm) state.points_mm.push_back(T.Apply(c));
  problem.UpdateZeroLengths(state);
  return state;
}

SolveProgress LeastSquaresPass(const SelfCalProblem& problem, const SelfCalOptions& options,
                               SelfCalState& state, SelfCalResult& res) {
  SolveProgress solve;
  SolveOptions& sopt = solve.options;
  sopt.max_iterations = options.max_iterations;
  // Plain least squares from the initial values first (fast, close even with gross errors),
  // then the robust (Cauchy) pass from there.
  sopt.cauchy_scale_um = 0.0;
  solve.report = SolveSelfCal(problem, sopt, state);
  res.iterations += solve.report.iterations;
  solve.last_was_plain = true;
  sopt.initial_trust_region_radius = 1e8;
  return solve;
}

void RobustPass(const SelfCalProblem& problem, const SelfCalOptions& options, SelfCalState& state,
                SolveProgress& solve, SelfCalResult& res) {
  if (!(options.reject_outliers && options.robust_scale_um > 0)) return;
  // Nothing to expose when no reading of the least-squares solution is beyond the threshold:
  // the first rejection round would take nothing out either, and the least-squares solution
  // stands (a clean survey: two solves fewer).
  const Screening sc = Screen(problem, state, options);
  bool beyond = false;
  for (std::size_t k = 0; k < sc.z.size() && !beyond; ++k) {
    beyond = problem.active[k] && std::abs(sc.z[k]) > sc.tau;
  }
  if (!beyond) return;
  SolveOptions& sopt = solve.options;
  // Only to expose the gross errors: a few iterations suffice, the rejection rounds re-solve.
  sopt.cauchy_scale_um = options.robust_scale_um;
  sopt.max_iterations = std::min(options.max_iterations, 10);
  sopt.refine_steps = false;
  solve.report = SolveSelfCal(problem, sopt, state);
  res.iterations += solve.report.iterations;
  solve.last_was_plain = false;
  sopt.cauchy_scale_um = 0.0;
  sopt.max_iterations = options.max_iterations;
  sopt.refine_steps = true;
}

void RejectionRounds(SelfCalProblem& problem, const TrackerReadings& readings,
                     const SelfCalOptions& options, SelfCalState& state, SolveProgress& solve,
                     SelfCalResult& res) {
  const SolveOptions& sopt = solve.options;
  SolveReport& rep = solve.report;
  for (int round = 0; round <= options.max_rejection_rounds; ++round) {
    const bool changed = options.reject_outliers && round < options.max_rejection_rounds &&
                         RejectRound(problem, readings, options, state, solve.last_was_plain, res);
    if (!changed && solve.last_was_plain) break;
    if (changed) problem.CheckCounting();
    rep = SolveSelfCal(problem, sopt, state);
    res.iterations += rep.iterations;
    res.rounds = round + 1;
    solve.last_was_plain = true;
  }
  if (!std::isfinite(rep.final_cost)) {
    throw DidNotConverge("laser-tracker self-calibration: " + rep.message);
  }
  // The answer is the least-squares optimum of the readings in use: a solve stopped by its
  // iteration limit (far trackers make the problem ill-conditioned) is continued.
  for (int extra = 0; extra < 4 && !rep.converged; ++extra) {
    rep = SolveSelfCal(problem, sopt, state);
    res.iterations += rep.iterations;
  }
  if (!rep.converged) {
    res.warnings.push_back(
        "the least-squares solve stopped after " + std::to_string(res.iterations) +
        " iterations without meeting its convergence tolerance: the result may be short of the "
        "optimum (" +
        rep.message + ")");
  }
}

void FixGaugeSign(SelfCalState& state) {
  if (state.trackers_mm.size() >= 4 && state.trackers_mm[3].z() < 0) {
    for (auto& u : state.trackers_mm) u.z() = -u.z();
    for (auto& u : state.points_mm) u.z() = -u.z();
  }
}

SelfCalCovariance Precision(const SelfCalProblem& problem, const SelfCalState& state,
                            const SelfCalOptions& options, SelfCalResult& res) {
  const auto mm = static_cast<std::size_t>(problem.num_points);
  const std::size_t n = state.trackers_mm.size();
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
  const bool complete = cov.point_block_um2.size() == mm && cov.coupling.size() == mm &&
                        cov.point_free_um2.size() == mm && cov.point_gauge_um2.size() == mm &&
                        cov.tracker_um2.size() == n;
  if (cov.rank_deficiency > 0 || !complete ||
      !(cov.condition_number <= options.max_condition_number)) {
    ThrowNotObservable(problem, state, cov, options);
  }
  WarnWeakGeometry(problem, state, res);
  return cov;
}

void AssembleResult(const SelfCalProblem& problem, const TrackerReadings& readings,
                    const SelfCalState& state, const SelfCalCovariance& cov, SelfCalResult& res) {
  const int m = readings.NumPoints();
  const std::vector<char> use = problem.PointsInUse();
  res.point_valid = use;
  res.trackers_mm = state.trackers_mm;
  for (const auto& C : cov.tracker_um2) {
    res.tracker_uncertainty_um.push_back(C.diagonal().cwiseMax(0.0).cwiseSqrt());
  }
  res.dead_path_mm = problem.ZeroLengthsMm(state);
  for (const Segment& s : problem.segments) {
    res.dead_path_tracker.push_back(s.tracker);
    res.dead_path_from_row.push_back(s.start_row);
    res.dead_path_zero_row.push_back(s.zero_point);
  }
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
}

void SpatialWarning(const SelfCalProblem& problem, const TrackerReadings& readings,
                    const SelfCalState& state, const SelfCalOptions& options, SelfCalResult& res) {
  if (!options.spatial_check) return;
  const auto mm = static_cast<std::size_t>(readings.NumPoints());
  const std::vector<char>& use = res.point_valid;
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
    if (problem.active[k]) ++active_count[static_cast<std::size_t>(problem.observations[k].point)];
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
        << active_count[d.row] << " readings fit (largest standardised residual " << worst_z[d.row]
        << " um): kept, as the readings show no gross error";
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

}  // namespace km::tracker::selfcal_stages
