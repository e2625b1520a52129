// The serial-machine (3-axis) model family of the discovery engine (engine.h): DBB circular
// tests of one plane, effects of the registry analysis/serial_effects (effect_list.h), signatures
// of analysis/dbb/signatures.h.
//
// Rows: the stacked in-plane radial deviations about the nominal centre of every trace
// (diagnosis.h MakeDiagnosisTrace). Groups: one per trace, with its LOCAL set-up columns
// {cos θ, sin θ, 1} (centre offset and radius: the linearised least-squares circle, [PM-600
// report] eq. 2.6). Effect columns are GLOBAL: one value per effect for the whole test set.
// The model is linear in the effects' linear parameters; shape parameters are candidate
// variants (reversal-spike decay width from a set, cyclic period from the strongest
// periodogram peak of the current gap) and are refined (golden section on the joint residual)
// when an effect is accepted and after every later step.
//
// Held-out tests: fold key = test_id (a cw/ccw pair is held out together; when no test_id
// holds both directions although both are present, cw and ccw of equal radius and feed are
// paired instead). With a single key nothing can be held out by test; each trace is then split
// into `sample_folds` interleaved sub-traces (blocks of 2° dealt in turn: block b → sub-trace
// b mod k, each with its own set-up columns and group) and the fold key is the sub-trace index
// — a prediction of unseen stretches of the same turns, which still rejects shapes that only
// fit noise. (Single samples are not interleaved: the noise floor is estimated from successive
// differences within a group, which must stay neighbours.)
//
// Servo lag ("servo_lag", [Fujita thesis] ch. 2): a position loop with gain K_pp and velocity
// feed-forward K_f keeps the axes (1 − K_f)/K_pp behind their command, so on a circle at
// ω = V/R every position-dependent error (backlash at the axis's real reversal, a cyclic error
// at the axis's real position) appears at θ − s·ω·τ, shifted the opposite way in cw and ccw.
// Once the model has effects, a delay τ ≥ 0 is offered: all terms and the set-up columns are
// evaluated at the shifted angles (the measured deviations stay where they were sampled). Its
// candidate column is the model's change per ms of delay at fixed values (a secant to the best
// delay of a coarse scan); an accepted delay is refined by golden section on the bounded
// refit, and again after every later step. The radius reduction of the same loop
// (servo_lag.h) is a radius change per test and stays in the set-up terms.
//
// Physical bounds (Physical(), and every refit is a bounded least-squares fit): the signs the
// physics of an effect fixes, with the value conventions of analysis/serial_effects/models:
//   reversal_spike_<a>  height h ≥ 0 (the axis sticks, then follows: an outward spike)
//   lateral_play_<a>    play p ≥ 0 (a clearance: the peak size of the sideways shift)
//   stick_slip          amplitude ≥ 0 (not a linear candidate; listed for completeness)
//   backlash_<a>        free by default: the step a DBB sees is the lost motion net of the
//                       control's backlash compensation, and backlash.h documents b < 0 as
//                       over-compensation (an inward step). With options.uncompensated_backlash
//                       (no compensation in the control) b ≥ 0. Bounding b on machines with
//                       over-compensated axes names the other axis's backlash instead (its
//                       45° content stands in) — a false discovery the sign cannot justify.
// Squareness, scale and servo mismatch, straightness and the cyclic error (c, d) may take
// either sign. A candidate whose joint fit would put any bounded value of the model (its own
// or an earlier effect's) beyond its bound is not physical.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "analysis/dbb/dbb_types.h"
#include "analysis/dbb/diagnosis.h"
#include "analysis/dbb/signatures.h"
#include "analysis/discovery/engine.h"
#include "analysis/serial_effects/registry.h"

namespace km::discovery {

struct SerialFamilyOptions {
  std::vector<double> spike_widths_deg = {0.5, 1.0, 2.0, 4.0};
  double cyclic_min_period_mm = 1.0;
  double cyclic_max_period_fraction = 1.0 / 3.0;  // of the smallest radius
  bool search_cyclic = true;
  bool refine_shapes = true;            // golden-section refinement of widths and periods
  bool uncompensated_backlash = false;  // backlash ≥ 0 (the control does not compensate it)
  int sample_folds = 5;                 // interleaved sub-traces when there is one test_id
  double resolution_um = 1e-6;          // data resolution (files: 6 decimals)
  // Effects not offered at a step: (step number from 1, effect name) — DiscoverSerial's
  // alternatives to a ladder that ended in "model misfit".
  std::vector<std::pair<int, std::string>> withheld;
  void Check() const;  // throws km::InvalidInput on nonsense
};

// One effect of a fitted model.
struct SerialEffectFit {
  serial_effects::EffectId id = serial_effects::EffectId::kSquareness;
  std::string name;                  // contract name with the plane's axis letters
  std::vector<double> shape;         // fixed shape parameters (registry order)
  std::vector<double> linear;        // fitted linear parameters
  std::vector<double> linear_sigma;  // their standard uncertainties
  std::vector<double> value;         // docs/formats.md §4 value(s)
  std::vector<double> sigma;         // standard uncertainty of each value
  std::string unit;
  double z_score = 0.0;                      // |value| / σ (norm over the RMS σ for two values)
  bool at_bound = false;                     // held at its physical bound by the fit
  std::map<std::string, double> parameters;  // every parameter by name (linear and shape)
  std::map<std::string, double> shape_map;   // shape parameters by name
};

// A fitted model: the set-up terms net of the effects' own first harmonic and mean, and the
// effects.
struct SerialModel {
  std::vector<SerialEffectFit> effects;
  double centre_um[2] = {0.0, 0.0};
  double centre_sigma_um[2] = {0.0, 0.0};
  double radius_um = 0.0;
  double radius_sigma_um = 0.0;
  Eigen::VectorXd residual;  // fitted − measured, per row (µm)
  double rss_um2 = 0.0;
  int dof = 0;
};

// What the family adds to a step beyond the engine's Evidence.
struct SerialStepNote {
  std::vector<std::string> indistinguishable_from;  // candidates the data cannot tell apart
};

class SerialFamily final : public ModelFamily {
 public:
  // `test_ids[k]` names the test of `traces[k]` (cw and ccw of one test share it).
  SerialFamily(const std::vector<dbb::DiagnosisTrace>& traces,
               const std::vector<std::string>& test_ids, dbb::Plane plane,
               SerialFamilyOptions options = {});

  FitState FitBase() override;
  std::vector<Candidate> Candidates(const FitState& fit) override;
  bool Physical(const Candidate& c, const Eigen::VectorXd& x, std::string* why) override;
  FitState Accept(const Candidate& c, const Eigen::VectorXd& x) override;
  Evidence Describe(const FitState& before, const Candidate& c,
                    const Eigen::VectorXd& contribution) override;
  std::vector<int> FoldKeys() const override;

  // The fitted model after the base fit (index 0) and after every accepted step.
  const std::vector<SerialModel>& History() const { return history_; }
  // One note per accepted step (same order as the engine's steps).
  const std::vector<SerialStepNote>& Notes() const { return notes_; }
  // The floor below which a gap is not an effect: the data resolution and the second-order
  // term of the bar length (max|g₀| + max|centre offset|)²/(2R) (the signatures are first
  // order in e/R). Use it as EngineOptions::resolution_um.
  double ResolutionUm() const { return resolution_um_; }
  // True when the traces were split into interleaved sub-traces (one test_id only).
  bool SplitIntoSubTraces() const { return split_; }
  std::string Name(serial_effects::EffectId id) const;
  dbb::Plane Plane() const { return plane_; }

 private:
  struct Term {  // an effect of the model or a candidate, shape fixed
    dbb::EffectColumns sig;
    int order = 0;  // registry position (priority when two cannot be told apart)
  };
  struct Bounded {  // result of a bounded joint fit
    Eigen::VectorXd x;
    Eigen::VectorXd residual;  // e0 − A x (measured − fitted, set-up free)
    double rss = 0.0;
    std::vector<bool> at_bound;
  };
  // Lower bound of the j-th linear parameter of an effect (−∞ when free).
  double LowerBound(serial_effects::EffectId id, int j) const;
  Bounded Fit(const std::vector<const Term*>& terms) const { return FitTo(e0_, terms); }
  Bounded FitTo(const Eigen::VectorXd& e0, const std::vector<const Term*>& terms) const;
  SerialModel MakeModel(const std::vector<Term>& terms, const Bounded& b) const;
  FitState StateOf(const std::vector<Term>& terms, const SerialModel& m) const;
  void RefineShapes(std::vector<Term>& terms, std::size_t first) const;
  const Term* Find(const Candidate& c) const;
  // Servo lag (serial_family_lag.cpp): the stack with every sample at the angle where the
  // axes are, `delay_ms` behind the command along the path; the bounded refit of the model's
  // terms there; the change of the model per ms of delay at fixed values (a secant from
  // `from_ms` to `to_ms`, or a derivative when they straddle the delay).
  static constexpr double kMaxDelayMs = 500.0;
  // The traces without their samples at an axis reversal itself (dbb::StackTraces), decided
  // at the commanded angles so that every servo-lag shift (StackAt) keeps the same rows.
  static std::vector<dbb::DiagnosisTrace> OffReversals(
      std::vector<dbb::DiagnosisTrace> groups);  // beyond half a second it is no position loop
  dbb::StackedTraces StackAt(double delay_ms) const;
  double DelayRss(double delay_ms) const;
  Eigen::VectorXd DelayColumn(double from_ms, double to_ms) const;
  void Restack(double delay_ms);
  void RefineDelay(double lo_ms, double hi_ms);
  void FinishStep();  // refit, delay column, history entry
  bool IsDelay(const Candidate& c) const;
  std::vector<Candidate> DelayCandidate(int step);
  Evidence DescribeDelay(const FitState& before, const Eigen::VectorXd& contribution) const;
  void AddDelayEffect(SerialModel& m, double sigma2) const;
  std::string VariantOf(const dbb::EffectColumns& sig) const;

  dbb::Plane plane_;
  SerialFamilyOptions opt_;
  dbb::StackedTraces p_;
  std::vector<int> fold_key_;        // per group
  std::vector<int> trace_of_group_;  // original trace of each group
  std::vector<dbb::DiagnosisTrace> traces_;
  std::vector<dbb::DiagnosisTrace> groups_;  // traces or sub-traces, at the commanded angles
  double delay_ms_ = 0.0;                    // servo lag in the model (0: none)
  double delay_offered_ms_ = 0.0;            // this step's delay candidate: its secant end
  Eigen::VectorXd delay_offered_col_;        // and its column
  Eigen::VectorXd delay_col_;                // the model's change per ms of delay
  std::vector<std::string> test_ids_;
  bool split_ = false;
  Eigen::VectorXd e0_;                    // y with each group's set-up part removed
  std::vector<Eigen::Vector3d> setup_y_;  // set-up coefficients of y per group
  double resolution_um_ = 1e-6;
  double rmin_mm_ = 0.0;
  double max_step_rad_ = 0.0;
  std::vector<Term> model_;
  std::vector<Term> pending_;                                 // this step's candidates
  std::map<std::string, std::vector<std::string>> confused_;  // offered → left out for it
  std::vector<SerialModel> history_;
  std::vector<SerialStepNote> notes_;
};

// The serial discovery: the engine's ladder (RunDiscovery) with the serial family. A greedy
// ladder can take a wrong first turn — e.g. backlash of the other axis, whose 45° content
// stands in for a servo mismatch plus the true backlash, after which the true effects explain
// too little of the remaining gap and the ladder ends in "model misfit". Then the ladder is
// run again with the effect of one step withheld at that step (each step in turn); a run that
// ends "complete" replaces it (the fewest effects, then the smallest unexplained gap). A run
// that ends in misfit is never replaced by another misfit. `engine.resolution_um` is raised to
// the family's floor (ResolutionUm()).
struct SerialRun {
  std::unique_ptr<SerialFamily> family;
  EngineResult result;
  int alternatives_tried = 0;
  std::string alternative;  // "" or which choice was withheld, e.g. "backlash_y at step 1"
};
SerialRun DiscoverSerial(const std::vector<dbb::DiagnosisTrace>& traces,
                         const std::vector<std::string>& test_ids, dbb::Plane plane,
                         const SerialFamilyOptions& options = {}, EngineOptions engine = {},
                         const ProgressFn& progress = {});

}  // namespace km::discovery
