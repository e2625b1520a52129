// Identification of the eight location errors of a trunnion table's rotary axes from R-test
// poses (docs/methods.md §17.2–17.4; [ISO 230-1], [ISO 10791-6]): Gauss–Newton on the exact
// model of analysis/rotary/rotary_model.h, each step the linear least-squares solution over the
// directions the poses determine.
//
// Identifiability: the Jacobian of the first-order model (all errors zero), its columns scaled
// to unit length, is decomposed by SVD; a singular value below rank_tolerance × the largest is a
// direction the poses do not determine. The rank is the number kept, the condition the ratio of
// the largest to the smallest kept. An error with a share in the null space gets no value: it is
// reported as not identifiable, and the groups of such errors are named in words
// (rotary_separability.h). σ of an identifiable error: the diagonal of s²·V_r (J_rᵀJ_r)⁻¹ V_rᵀ
// (column scaling undone), s² = Σ residual² / (3N − rank).
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "analysis/rotary/rotary_separability.h"
#include "analysis/rotary/rotary_types.h"

namespace km::rotary {

struct IdentifyOptions {
  int max_iterations = 20;
  // Stop when the scaled step is below step_tolerance × (1 + |scaled errors|).
  double step_tolerance = 1e-10;
  // Singular values of the column-scaled first-order Jacobian below this × the largest are
  // directions the poses do not determine.
  double rank_tolerance = 1e-8;
  // An error whose squared share in the undetermined directions exceeds this has no value.
  double null_share_tolerance = 1e-6;
  void Check() const;
};

struct LocationErrorEstimate {
  bool identifiable = false;
  double value = 0.0;  // µm or µrad; 0 and meaningless when not identifiable
  double sigma = 0.0;  // standard uncertainty from the residual, same unit
};

struct RotaryIdentification {
  Kinematics kinematics = Kinematics::kAcTrunnion;
  std::array<LocationErrorEstimate, kLocationErrorCount> errors{};
  std::size_t poses = 0;
  std::size_t observations = 0;  // 3 per pose
  std::size_t rank = 0;
  std::optional<double> condition;            // none when nothing is determined
  std::vector<double> singular_values;        // column-scaled first-order Jacobian, largest first
  std::vector<NullSpaceGroup> not_separable;  // what the poses cannot determine, in words
  double sigma_um = 0.0;         // s: the standard deviation of one reading from the residual
  double measured_rms_um = 0.0;  // RMS of the measured components (before)
  double residual_rms_um = 0.0;  // RMS of the residual components (after)
  std::vector<std::array<double, 3>> residuals_um;  // measured − model, per pose
  int iterations = 0;
  bool converged = false;
};

// Throws InvalidInput for bad options or a test with fewer than 4 poses or non-finite values.
RotaryIdentification IdentifyLocationErrors(const RotaryTest& test,
                                            const IdentifyOptions& options = {});

// The identification repeated on other readings of the same poses (the Monte Carlo draws of
// rotary_uncertainty.h). What the poses determine depends on the poses alone: it is found once,
// with the solution of the file's own readings; each Solve is the same Gauss–Newton over the
// same determined directions, warm-started from that solution.
class Reidentification {
 public:
  // Throws as IdentifyLocationErrors.
  explicit Reidentification(const RotaryTest& test, const IdentifyOptions& options = {});
  ~Reidentification();
  Reidentification(const Reidentification&) = delete;
  Reidentification& operator=(const Reidentification&) = delete;

  std::size_t Readings() const;            // 3 per pose
  std::vector<double> MeasuredUm() const;  // the file's readings, x, y, z per pose
  std::array<bool, kLocationErrorCount> Identifiable() const;
  // The eight errors (those not identifiable meaningless) from `measured_um` (Readings()
  // values); `converged` (optional) tells whether the Gauss–Newton converged.
  LocationErrors Solve(std::span<const double> measured_um, bool* converged = nullptr) const;
  // √diag of D⁻¹V_r (J_rᵀJ_r)⁻¹V_rᵀD⁻¹ at the solution of the file's readings: the first-order
  // standard uncertainty of each determined error per µm of reading uncertainty (µm/µm,
  // µrad/µm); σ of IdentifyLocationErrors is s times it.
  LocationErrors SigmaPerUnitReading() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The model's displacement (µm) at every pose for given location errors (e.g. the result's,
// the undetermined ones at 0).
std::vector<std::array<double, 3>> ModelDisplacements(const RotaryTest& test,
                                                      const LocationErrors& errors);

}  // namespace km::rotary
