// Kinematic calibration of a hexapod from DBB circular tests ([PM-600 report] §2.2, §2.3, §5.2).
//
// Parameters K (24, µm, relative to the nominal model the controller used during the tests):
//   K[0..5]          Δo_j   strut offsets (true strut length − length the nominal commands)
//   K[6 + 3j + c]    ΔQ_j,c base joint j, coordinate c (true − nominal), machine frame
// Platform joints and tool length are taken as known ([PM-600 report]: measured by CMM).
//
// Measurement model for one sample of one test (commanded pose T, controller commands
// s = IK_nominal(T)):   f(K) = |tip(FK_{nominal+K}(s)) − F| ,
// residual r = 1000·(f(K) − (R_DBB + ΔR/1000)) µm. The pose derivative follows from the implicit
// function theorem on IK_K(T') = s:  ∂f/∂Δo_j = w_j,  ∂f/∂ΔQ_j = w_j·u_jᵀ,  w = J⁻ᵀ[e; 0],
// with J = ∂s/∂T at the real pose, u_j the unit strut vectors and e the unit bar vector.
// Gauss–Newton on this model is [PM-600 report] eqs. 2.2–2.5 (ΔR = A·ΔK); Ceres solves it.
//
// Methods:
//  * absolute (jig, [PM-600 report] §2.3.3): F is the measured fixed ball of each test; all 24
//    parameters are normally observable.
//  * centre_corrected (conventional): F of every test is unknown and estimated as a nuisance
//    parameter. A rigid motion of the whole base (6 combinations) is then invisible; the rank
//    analysis (SVD of the Jacobian with the nuisance columns projected out) finds every
//    unobservable combination and fixes one parameter per null direction (column-pivoted QR
//    of the null-space basis, base-joint coordinates preferred), listed in fixed_parameters.
//    For flat tests the fixed ball's height (along the plane normal) is not estimated: a
//    horizontal bar is insensitive to it to first order (see CalibrationTestData).
//
// Problem description (this header, calibration.cpp) is separate from the Ceres solve
// (calibration_ceres.cpp, cost functor in calibration_cost.h).
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/core/progress.h"
#include "analysis/dbb/dbb_types.h"
#include "analysis/hexapod/calibration_sample.h"
#include "analysis/hexapod/kinematics.h"

namespace km::hexapod {

constexpr int kNumKinematicParameters = 24;
using ParameterVector = Eigen::Matrix<double, kNumKinematicParameters, 1>;

enum class CalibrationMethod { kAbsolute, kCentreCorrected };
const char* ToString(CalibrationMethod m);  // "absolute" / "centre_corrected"

// Name of parameter i as in the JSON report: "strut_offset_um[j]", "base_joint_offset_um[j][c]".
std::string ParameterName(int i);

// Geometry nominal + K (K in µm).
HexapodGeometry ApplyParameters(const HexapodGeometry& nominal, const ParameterVector& k_um);
// K (µm) such that ApplyParameters(nominal, K) == actual.
ParameterVector ParameterDifference(const HexapodGeometry& nominal, const HexapodGeometry& actual);

struct CalibrationOptions {
  CalibrationMethod method = CalibrationMethod::kAbsolute;
  int max_iterations = 50;
  // Relative tolerances; the forward kinematics inside the residual is exact to ~1e-10 µm, so
  // tighter values only make the solver chase round-off.
  double function_tolerance = 1e-9;
  double parameter_tolerance = 1e-8;
  double gradient_tolerance = 1e-12;
  // The model is nearly linear over the parameter range ([PM-600 report] iterates plain
  // Gauss–Newton): a wide initial trust region makes the first steps full Gauss–Newton steps.
  double initial_trust_region_radius = 1e10;
  // A singular value below rank_tolerance·σ_max of the (nuisance-projected) Jacobian counts as
  // an unobservable direction.
  double rank_tolerance = 1e-6;
  // Use at most this many samples per test (evenly thinned); 0 = all.
  int max_samples_per_test = 0;

  // Throws km::InvalidInput naming the bad option (analysis/core/option_check.h). The Ceres
  // solver options are made from these in calibration_ceres.cpp (CalibrationSolverOptions).
  void Check() const;
};

struct CalibrationTestData {
  std::string test_id;
  dbb::Direction direction = dbb::Direction::kCcw;
  double tool_length_mm = 0.0;
  bool fixed_ball_known = false;  // absolute mode
  Eigen::Vector3d fixed_ball_mm;  // given (absolute) or initial guess (= centre_mm)
  // Centre-corrected flat tests (z_offset = 0): the bar lies in the plane, so the fixed ball's
  // coordinate along the plane normal changes the reading only to second order; it is kept at
  // the commanded centre (index 0..2 of that machine axis), -1 when all three are estimated.
  int ball_fixed_axis = -1;
  std::vector<CalibrationSample> samples;
};

// Everything the solver needs; no Ceres types.
struct CalibrationProblem {
  HexapodGeometry nominal;
  CalibrationOptions options;
  std::vector<CalibrationTestData> tests;
  std::array<bool, kNumKinematicParameters> fixed{};  // filled by AnalyzeObservability
  std::vector<double> singular_values;                // of the projected Jacobian, descending
};

// Converts DBB tests to a problem. Throws km::InvalidInput (test id, field) when a test lacks
// tool_length_mm, has no samples, or (absolute method) lacks fixed_ball_mm.
CalibrationProblem BuildCalibrationProblem(const HexapodGeometry& nominal,
                                           const std::vector<dbb::DbbTest>& tests,
                                           const CalibrationOptions& options);

// Residuals (µm) and Jacobians at K and the given fixed balls: J_k (m×24), J_f (m×3 per test,
// block-diagonal, stored as m×3 with rows of test t belonging to ball t).
struct ResidualEvaluation {
  Eigen::VectorXd residual_um;
  Eigen::MatrixXd jac_k;  // ∂r/∂K (µm/µm)
  Eigen::MatrixXd jac_f;  // ∂r/∂F_t (µm/µm), m×3
  std::vector<int> test_of_row;
};
ResidualEvaluation EvaluateResiduals(const CalibrationProblem& problem, const ParameterVector& k_um,
                                     const std::vector<Eigen::Vector3d>& fixed_balls_mm);

// Rank analysis at K = 0: sets problem.fixed and problem.singular_values.
void AnalyzeObservability(CalibrationProblem& problem);

struct CalibrationResult {
  CalibrationMethod method = CalibrationMethod::kAbsolute;
  ParameterVector parameters_um = ParameterVector::Zero();
  ParameterVector uncertainty_um = ParameterVector::Zero();  // 1σ; 0 for fixed parameters
  // Covariance of the 24 parameters (µm²), σ²·(AᵀA)⁻¹ over the free ones with the nuisance
  // fixed balls eliminated; rows/columns of fixed parameters are zero.
  Eigen::Matrix<double, kNumKinematicParameters, kNumKinematicParameters> covariance_um2 =
      Eigen::Matrix<double, kNumKinematicParameters, kNumKinematicParameters>::Zero();
  std::vector<int> fixed_parameter_indices;
  std::vector<std::string> fixed_parameters;
  std::vector<Eigen::Vector3d> fixed_balls_mm;  // per test (given or estimated)
  double residual_rms_um = 0.0;
  double condition_number = 0.0;  // of the projected Jacobian over the free parameters
  std::vector<double> singular_values;
  int iterations = 0;
  bool converged = false;
  HexapodGeometry calibrated;  // nominal + parameters
};

// Ceres solve of a prepared problem (calibration_ceres.cpp). Throws km::DidNotConverge.
CalibrationResult SolveCalibration(const CalibrationProblem& problem);

namespace internal {
// Residual rms, condition number and covariance at the solution (used by SolveCalibration).
void FillStatistics(const CalibrationProblem& problem, CalibrationResult& result);
}  // namespace internal

// Build + AnalyzeObservability + SolveCalibration.
CalibrationResult Calibrate(const HexapodGeometry& nominal, const std::vector<dbb::DbbTest>& tests,
                            const CalibrationOptions& options);

// ---- Post-calibration prediction, [PM-600 report] eq. 5.2 ----
//
//   R̂²_i = R̂¹_i + f(K2) − f(K1),   f(K_nc) = |tip(FK_{K2}(IK_{K_nc}(T_i))) − F|
//
// i.e. the real machine is approximated by the calibrated one and only the controller's model
// changes from K1 (nominal) to K2. F during the measurement = the given / estimated fixed ball;
// after calibration F = fixed_ball_mm (jig) or, for a conventional set-up, the centre where the
// recalibrated spindle stands (= centre_mm under K2). Non-kinematic errors in the measured trace
// (gravity, friction, noise) are carried over unchanged.
struct TestPrediction {
  std::string test_id;
  dbb::Direction direction = dbb::Direction::kCcw;
  double circularity_before_um = 0.0;
  double predicted_circularity_after_um = 0.0;
  std::vector<double> predicted_dr_um;  // same samples as the test
};
// fixed_balls_mm: per test, the fixed ball during the measurement; empty or a missing entry →
// the given fixed_ball_mm, else predicted from the calibrated model (conventional set-up).
std::vector<TestPrediction> PredictAfterCalibration(
    const HexapodGeometry& nominal, const HexapodGeometry& calibrated,
    const std::vector<dbb::DbbTest>& tests, const std::vector<Eigen::Vector3d>& fixed_balls_mm);

// ---- Test-set reduction study, [PM-600 report] §5.2.3 ----
// Tests are grouped by test_id (a CW/CCW pair drops together). From k = N groups down to
// min_groups: drop greedily the group whose removal gives the smallest mean predicted
// circularity over ALL tests, recalibrate, record.
struct ReductionStep {
  int groups_kept = 0;
  std::vector<std::string> kept_test_ids;
  std::string dropped_test_id;  // empty for the full set
  double mean_predicted_circularity_um = 0.0;
  double max_predicted_circularity_um = 0.0;
  double condition_number = 0.0;
};
// on_calibration, when given, is called before each of the study's calibrations with the
// fraction done and "calibration k of n": a caller follows the progress there, and may stop the
// study by throwing from it.
std::vector<ReductionStep> TestSetReductionStudy(const HexapodGeometry& nominal,
                                                 const std::vector<dbb::DbbTest>& tests,
                                                 const CalibrationOptions& options, int min_groups,
                                                 const ProgressFn& on_calibration = {});

}  // namespace km::hexapod
