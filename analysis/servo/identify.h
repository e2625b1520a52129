// Identification of a hexapod's masses and friction from servo loads recorded without a
// cutting load ([PM-600 report] §3.3.5, table 3.2; docs/methods.md §12): platform mass and
// centre of gravity, motor mass m_S, strut equivalent mass m_T, ball-screw friction f0_j and
// base-joint friction t0, t1, by linear least squares on the statics of load_model.h. The
// t1 columns need the axial gravity ĝ_j, which depends on the masses: the problem is solved
// again with ĝ from the latest estimate until the parameters settle (the covariance is that of
// the last linear problem).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "analysis/hexapod/kinematics.h"
#include "analysis/hexapod/statics.h"
#include "analysis/servo/joint_ramp.h"
#include "analysis/servo/load_model.h"
#include "analysis/servo/servo_types.h"

namespace km::servo {

struct IdentifyOptions {
  // Rows of a strut are used when it moves at >= this fraction of its median rate (and the
  // tool tip likewise), after `reversal_skip_mm` of strut travel since its last reversal.
  double min_rate_fraction = 0.2;
  double reversal_skip_mm = 1.0;
  int max_iterations = 20;           // ĝ refreshed for t1
  double min_singular_ratio = 1e-4;  // identifiability threshold (linear_lsq.h)
  bool inertia = true;               // the platform's inertia (eq. 3.13) in the model
  bool estimate_ramp = true;         // the joint-friction ramp after reversals (joint_ramp.h)
  // Throws km::InvalidInput naming the field when a value is out of range.
  void Check() const;
};

struct ParameterNote {
  std::string parameter;  // LoadParamName
  std::string reason;
};

struct IdentifyResult {
  hexapod::MachinePhysics identified;  // the machine's physics with the identified values
  LoadVector theta = LoadVector::Zero();
  LoadVector sigma = LoadVector::Zero();          // of θ
  std::array<double, 3> platform_cog_sigma_mm{};  // of the centre itself
  std::vector<ParameterNote> fixed;               // held at the machine's value
  std::array<double, 6> residual_rms_N{};
  std::array<std::size_t, 6> rows_used{};
  double residual_sigma_N = 0.0;  // σ̂ of all rows
  double condition_number = 0.0;
  int iterations = 0;
  std::size_t samples = 0;
  std::optional<RampEstimate> joint_ramp;  // with IdentifyOptions::estimate_ramp
};

// `machine` supplies the geometry, gravity vector, the fixed masses m_B, m_J, lengths l1–l3,
// and the values of parameters the data cannot identify. Throws km::InvalidInput (a file is
// not a hexapod servo file, or belongs to another machine) or km::NotObservable.
IdentifyResult IdentifyLoads(const hexapod::HexapodGeometry& geometry,
                             const hexapod::MachinePhysics& machine,
                             const std::vector<ServoFile>& files,
                             const IdentifyOptions& options = {});

}  // namespace km::servo
