// The model-gap discovery engine shared by every machine family (serial 3-axis machines,
// hexapods): forward stepwise model building where each step adds one named physical effect.
//
// A family (ModelFamily) owns the physics: it fits its base model, offers candidate effects
// linearised at the current fit, and refits the model when a candidate is accepted. The engine
// owns the step loop — fit, gap, candidates, scoring, acceptance, evidence, stop rule:
//
//  * gap g = residual of the current fit (rows grouped by test; columns of the model's
//    Jacobian J are global or local to one test, e.g. a test's fixed-ball position);
//  * candidate k = an offset o_k (its fixed part at the starting values) and columns A_k (its
//    free parameters); the linearised fit of [J, A_k] to g − o_k gives its RSS and its values;
//  * local columns are eliminated test by test (projection), so every score below works on
//    Gram matrices per fold;
//  * acceptance needs all of: the values physically possible (family bounds); the nested-model
//    F-test p < max_p_value; a better prediction of tests held out of the fit (k-fold over
//    test groups, PRESS(M ∪ k) < (1 − min_cv_gain)·PRESS(M)); and a practical improvement (the
//    RSS drop is at least min_practical_fraction of the gap's excess over the noise floor);
//  * it stops when the gap is at the noise floor, when no candidate qualifies (verdict "model
//    misfit" if the gap is still above misfit_ratio × noise floor, else "complete"), or after
//    max_steps.
//
// Noise floor: σ of the white part of the gap from successive differences inside each test,
// 1.4826·MAD(Δg)/√2 — smooth effects barely change Δg at DBB sampling, so this is what no
// smooth model can explain.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "analysis/core/progress.h"

namespace km::discovery {

struct FitState {
  Eigen::VectorXd residual;           // n, µm
  Eigen::MatrixXd jacobian;           // n × p (free parameters of the fitted model)
  std::vector<int> column_group;      // per column: −1 global, g ≥ 0 local to group g
  std::vector<int> row_begin;         // first row of each group (+ n at the end)
  std::vector<std::string> in_model;  // effect names, in order
};

struct Candidate {
  std::string effect;                        // name
  std::string variant;                       // shape, e.g. "ramp_mm = 2" ("" when none)
  int priority = 0;                          // lower wins when two cannot be told apart
  Eigen::VectorXd offset;                    // n (may be empty: zero)
  Eigen::MatrixXd columns;                   // n × q
  std::vector<std::string> parameter_names;  // q
};

// Describes a step for people: which features of the gap made the effect the right one.
struct Evidence {
  std::string sentence;
  std::map<std::string, double> figures;
};

class ModelFamily {
 public:
  virtual ~ModelFamily() = default;
  virtual FitState FitBase() = 0;
  virtual std::vector<Candidate> Candidates(const FitState& fit) = 0;
  // Whether the linear estimate `x` of the candidate's parameters is physically possible;
  // `why` names the violated bound.
  virtual bool Physical(const Candidate& c, const Eigen::VectorXd& x, std::string* why) = 0;
  // Nonlinear refit of the model with the candidate added (its estimate as start).
  virtual FitState Accept(const Candidate& c, const Eigen::VectorXd& x) = 0;
  virtual Evidence Describe(const FitState& before, const Candidate& c,
                            const Eigen::VectorXd& contribution) = 0;
  // Groups held out together in the cross-validation (e.g. a CW/CCW pair): fold key per group.
  // Groups with one key also form one cluster of the test-level inference.
  virtual std::vector<int> FoldKeys() const = 0;
  // σ of what repeated measurements do not share (e.g. from CW/CCW pairs at the same angles),
  // 0 when the data cannot tell. Unlike the white floor from successive differences it
  // includes slowly correlated (coloured) noise, so a gap at this level is no misfit.
  virtual double RepeatabilityFloor(const FitState&) const { return 0.0; }
  // Describes a gap no candidate explains: where it is, what it depends on.
  virtual Evidence DescribeGap(const FitState&) const { return {}; }
};

struct EngineOptions {
  double max_p_value = 1e-6;
  int folds = 5;
  double min_cv_gain = 0.02;
  double min_practical_fraction = 0.3;
  double noise_stop_ratio = 1.05;
  double misfit_ratio = 1.3;
  double confound_ratio = 0.1;  // part of a candidate's column left after projecting the model
  // A column with less left is still identified when its parameter's |estimate| is at least
  // determined_t times its σ (0: never).
  double determined_t = 0.0;
  int max_steps = 8;
  double resolution_um = 1e-6;
  // Test-level inference: a candidate must also pass a cluster-robust Wald test (clusters = fold
  // keys, F(q, G − 1)), which holds when the samples of a test are correlated, not independent.
  // Used when there are at least min_clusters clusters.
  bool cluster_inference = false;
  int min_clusters = 6;
  void Check() const;
};

struct GroupGap {
  int group = 0;
  double rms_before_um = 0.0;
  double rms_after_um = 0.0;
};

struct CandidateScore {
  std::string effect;
  std::string variant;
  double rss_after_um2 = 0.0;      // linearised
  double press_um2 = 0.0;          // cross-validated
  double log10_p_value = 0.0;      // the less significant of the two tests below
  double log10_p_white = 0.0;      // F-test counting every sample as independent
  double log10_p_clustered = 0.0;  // cluster-robust Wald test (0 when not used)
  bool identifiable = true;
  bool physical = true;
  std::string rejected_because;  // "" when it qualified
  Eigen::VectorXd estimate;
};

struct Step {
  std::string added_effect;
  std::string variant;
  double gap_rms_before_um = 0.0;
  double gap_rms_after_um = 0.0;
  double rss_before_um2 = 0.0;
  double rss_after_um2 = 0.0;
  double press_before_um2 = 0.0;
  double press_after_um2 = 0.0;
  double f_statistic = 0.0;
  double log10_p_value = 0.0;
  int df_numerator = 0;
  int df_denominator = 0;
  Evidence evidence;
  std::vector<GroupGap> groups;
  std::vector<CandidateScore> candidates;  // every candidate tried at this step
  FitState before;
  FitState after;
};

// The verdict of a discovery (docs/formats.md §3.7 `verdict`): complete — the gap is at the noise
// floor or no candidate is needed; model misfit — what is left is above what repeat tests
// explain and no candidate qualifies (a physical effect the family does not offer).
enum class Verdict { kComplete, kModelMisfit };
// Why the steps stopped (`stop_reason` in words, `stop_code` for programs).
enum class StopReason { kAtNoiseFloor, kMaxSteps, kNoCandidateLeft, kNoCandidateQualifies };

const char* ToString(Verdict v);     // "complete", "model misfit"
const char* ToString(StopReason r);  // "the gap is at the noise floor", …
const char* StopCode(StopReason r);  // "noise_floor", "max_steps", "no_candidate_left", …
// The verdict of its spelling (ToString); nullopt for any other text.
std::optional<Verdict> ParseVerdict(std::string_view text);

struct EngineResult {
  FitState base;
  std::vector<Step> steps;
  FitState final_fit;
  double unexplained_rms_um = 0.0;
  double noise_floor_um = 0.0;
  double repeatability_floor_um = 0.0;
  Verdict verdict = Verdict::kComplete;
  StopReason stop_reason = StopReason::kAtNoiseFloor;
  std::vector<CandidateScore> last_candidates;  // at the stop
  Evidence misfit;                              // when the verdict is kModelMisfit
};

// progress, when given, hears before each fit the fraction of the steps reached
// (step / (max_steps + 1), at most 0.95) and what is being fitted; it may stop the run by
// throwing.
EngineResult RunDiscovery(ModelFamily& family, const EngineOptions& options = {},
                          const ProgressFn& progress = {});

// Robust white-noise σ of a residual grouped by rows: 1.4826·MAD(Δ)/√2 over all groups.
double NoiseFloor(const Eigen::VectorXd& residual, const std::vector<int>& row_begin);

}  // namespace km::discovery
