// The named stages of SelfCalibrate (tracker_selfcal.cpp), in the order it runs them, and the
// spatial check (tracker_spatial_check.cpp). Internal to the tracker library.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "analysis/tracker/selfcal_problem.h"
#include "analysis/tracker/selfcal_result.h"
#include "analysis/tracker/selfcal_solver.h"
#include "analysis/tracker/tracker_types.h"

namespace km::tracker::selfcal_stages {

// What a figure the survey cannot give is reported as.
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One point id a commanded point; tracker guesses of existing trackers within 100 m of the
// machine origin (InvalidInput otherwise).
void CheckReadings(const TrackerReadings& readings);

// 1. Each tracker initialised in the machine frame, one tracker at a time (initial_rms_um), then
// 2. everything moved into the gauge frame; the notes of the readings (beam breaks taken as
// re-zeroed elsewhere) become warnings.
SelfCalState Initialise(const SelfCalProblem& problem, const TrackerReadings& readings,
                        SelfCalResult& res);

// The solve carried from pass to pass: the solver options, the last report, and whether the last
// solve was plain least squares.
struct SolveProgress {
  SolveOptions options;
  SolveReport report;
  bool last_was_plain = true;
};

// 3a. Plain least squares from the initial values (fast, close even with gross errors).
SolveProgress LeastSquaresPass(const SelfCalProblem& problem, const SelfCalOptions& options,
                               SelfCalState& state, SelfCalResult& res);
// 3b. A short robust (Cauchy) pass, only to expose the gross errors (when rejecting, and only
// when a reading of the least-squares solution is beyond the rejection threshold).
void RobustPass(const SelfCalProblem& problem, const SelfCalOptions& options, SelfCalState& state,
                SolveProgress& solve, SelfCalResult& res);
// 3c. Rejection rounds with least-squares re-solves until the last solve was plain and nothing
// changed; then the least-squares optimum is reached (DidNotConverge, or a warning when the
// solve stops short of its tolerance).
void RejectionRounds(SelfCalProblem& problem, const TrackerReadings& readings,
                     const SelfCalOptions& options, SelfCalState& state, SolveProgress& solve,
                     SelfCalResult& res);
// 4. Gauge sign: z of tracker 4 > 0 (mirror image otherwise).
void FixGaugeSign(SelfCalState& state);
// 5. Residuals, σ, covariance and observability of the solution (NotObservable), with warnings
// for weak or ambiguous geometry that still solves.
SelfCalCovariance Precision(const SelfCalProblem& problem, const SelfCalState& state,
                            const SelfCalOptions& options, SelfCalResult& res);
// 6. Results in the gauge frame and, after the best fit, in the commanded frame.
void AssembleResult(const SelfCalProblem& problem, const TrackerReadings& readings,
                    const SelfCalState& state, const SelfCalCovariance& cov, SelfCalResult& res);
// 7. Spatial consistency of the map: a warning naming the points; nothing is discarded.
void SpatialWarning(const SelfCalProblem& problem, const TrackerReadings& readings,
                    const SelfCalState& state, const SelfCalOptions& options, SelfCalResult& res);

// Rejection (tracker_rejection.cpp). Residuals divided by √(1 − h), h the leverage of the reading
// within its point block; readings without redundancy (1 − h < 1e-3) get 0 and are marked not
// `testable`.
std::vector<double> StandardisedResiduals(const SelfCalProblem& problem, const SelfCalState& state,
                                          const std::vector<double>& r,
                                          std::vector<char>* testable = nullptr);
// The residuals of the readings, standardised by their leverage, and the rejection threshold:
// outlier_k robust σ of the testable ones, at least outlier_floor_um.
struct Screening {
  std::vector<double> r, z;
  double tau = 0.0;
};
Screening Screen(const SelfCalProblem& problem, const SelfCalState& state,
                 const SelfCalOptions& options);
// One round of rejection on the current solution (threshold ×3 after the robust pass, whose
// solve is stopped early); true when a reading was taken out, each listed in res.rejected.
bool RejectRound(SelfCalProblem& problem, const TrackerReadings& readings,
                 const SelfCalOptions& options, const SelfCalState& state, bool last_was_plain,
                 SelfCalResult& res);

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
                                                const std::vector<char>& use, double k);

}  // namespace km::tracker::selfcal_stages
