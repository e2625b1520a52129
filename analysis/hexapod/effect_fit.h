// Calibration with effects ([PM-600 report] ch. 5 eq. 5.3, [Joint patent] formulas 15–20): the
// 24 kinematic parameters (calibration.h) and the free parameters of a set of error effects
// (effects/effect.h) fitted together to DBB tests by damped Gauss–Newton, with uncertainties.
// A calibration that ignores a present effect absorbs it into wrong kinematic parameters; this
// one models it:
//
//   r = 1000·(|tip(FK_{nominal+K}(s + Δs(p)), l + Δl(p)) − F| − L_measured)     [µm]
//   ∂r/∂Δo_j = w_j,  ∂r/∂ΔQ_j = w_j u_jᵀ,  ∂r/∂Δs_j[mm] = 1000 w_j,
//   ∂r/∂l[mm] = −1000 eᵀ R e_z (the tip moves along the spindle axis at a fixed platform),
//   ∂r/∂F = −1000 eᵀ,  w = J⁻ᵀ[e; 0]
//
// with the effect derivatives ∂Δs/∂p, ∂Δl/∂p by central differences of the effect models.
// Unobservable kinematic combinations are fixed as in the plain calibration
// (AnalyzeObservability). Effect parameters stay inside their bounds.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/hexapod/calibration.h"
#include "analysis/hexapod/effects/registry.h"
#include "analysis/hexapod/effects/test_path.h"

namespace km::hexapod {

// The data of a fit: the calibration problem (samples, fixed balls, observability) and the
// same samples prepared for the effects.
struct EffectFitData {
  CalibrationProblem problem;
  PreparedTests prepared;
  std::vector<int> row_begin;  // first residual row of each test (+ total at the end)
  int rows() const { return row_begin.empty() ? 0 : row_begin.back(); }
};

// Builds the problem; tests are thinned to max_samples_per_test (0: all) before anything.
EffectFitData PrepareEffectFit(const HexapodGeometry& nominal, const MachinePhysics* physics,
                               const std::vector<dbb::DbbTest>& tests,
                               const std::vector<std::optional<double>>& start_time_s,
                               CalibrationMethod method, int max_samples_per_test);

// Sensitivity of one residual row to the realised strut lengths and the tool length (µm/mm).
using RowSensitivity = Eigen::Matrix<double, 7, 1>;

// An input the fit holds at the machine file's value (K_stiff1, the platform's mass and centre
// of gravity when not fitted), its standard uncertainty, and the shift of every fitted
// parameter when the input moves by it (the refit's first-order response; added in quadrature
// to the statistical σ).
struct HeldInput {
  std::string name;  // "K_stiff1_mm_per_N", "platform_mass_kg", "platform_cog_mm[2]"
  std::string unit;
  double value = 0.0;
  double u = 0.0;
  std::vector<std::vector<double>> effect_shift;  // [effect][parameter], 0 when not fitted
};

struct EffectFitResult {
  ParameterVector k_um = ParameterVector::Zero();
  ParameterVector k_sigma_um = ParameterVector::Zero();
  std::vector<ActiveEffect> effects;              // fitted values
  std::vector<std::vector<double>> effect_sigma;  // statistical ⊕ held inputs (below)
  std::vector<std::vector<double>> effect_sigma_statistical;
  std::vector<HeldInput> held_inputs;
  std::vector<Eigen::Vector3d> fixed_balls_mm;
  Eigen::VectorXd residual_um;           // all rows, tests in order
  Eigen::MatrixXd jacobian;              // n × free parameters, at the solution
  std::vector<int> column_test;          // −1: global column, t: nuisance of test t
  std::vector<std::string> column_name;  // e.g. "strut_offset_um[2]", "joint_friction.torque_Nm"
  // The tests' statics (strut frames, gravity loads) on the geometry of this fit's kinematic
  // parameters, which the effects were evaluated with (null: the model geometry's).
  std::shared_ptr<const PreparedTests> statics;
  std::vector<RowSensitivity> sensitivity;
  double rss_um2 = 0.0;
  int dof = 0;
  double residual_rms_um = 0.0;
  double condition_number = 0.0;
  int iterations = 0;
  // True only when the cost stopped changing (relative change below the tolerance, or no step
  // left that the linearised model says would lower it). `stop_reason` says which, or why not:
  // "converged", "stalled: …" (the damped steps no longer lower the cost although the linear
  // model predicts they should), "iteration limit".
  bool converged = false;
  std::string stop_reason;
  // Free effect parameters that ended on a bound (value clamped there): they are held at the
  // bound for the uncertainties, and their σ is NaN (not estimated).
  std::vector<std::vector<bool>> effect_at_bound;
  // σ are the larger of the usual (white-residual) estimate and the test-level one (the
  // delete-one-cluster jackknife), which holds when the residuals of a test are correlated with
  // each other or carry a systematic misfit: clusters are the tests with one test_id (a CW/CCW
  // pair).
  int clusters = 0;
};

struct EffectFitOptions {
  int max_iterations = 40;
  double relative_tolerance = 1e-10;  // on the cost
  // When no step lowers the cost: a minimum if the linear model predicts a decrease below this
  // fraction of the cost, else "stalled" (converged false).
  double stall_tolerance = 1e-4;
  void Check() const;  // throws km::InvalidInput naming the option out of its range
};

// Fits from `start` (k and effect values; balls from the data). The effects in `start` with
// their parameters' `free` flags define the model. The effects load the struts as the machine
// is built: the statics are evaluated on the geometry of start's kinematic parameters, and once
// more on the fitted geometry when the fit moved it by more than 10 µm (one refit).
EffectFitResult FitWithEffects(const EffectFitData& data, const EffectFitResult& start,
                               const EffectFitOptions& options = {});

// Adds to the σ of `fit` (effect and kinematic parameters) the uncertainty of the inputs its
// effects hold at the machine file's values (MachinePhysics::u_*), each by the first-order
// response of the refit to a change of the input by its u: δθ = −(JᵀJ)⁻¹Jᵀ ∂r/∂h·u.
// FitWithEffects does this; nothing is added without the machine's gravity data.
void PropagateHeldInputs(const EffectFitData& data, EffectFitResult& fit);

// A starting point: kinematic parameters 0 and the effects at their defaults for this set.
EffectFitResult StartingPoint(const EffectFitData& data,
                              const std::vector<const HexapodEffect*>& effects);

// First-order change of every residual row caused by adding `effect` with parameter values
// `values` to the fitted model (effect models evaluated alone, rows in order).
Eigen::VectorXd EffectContribution(const EffectFitData& data, const EffectFitResult& fit,
                                   const ActiveEffect& effect);

}  // namespace km::hexapod
