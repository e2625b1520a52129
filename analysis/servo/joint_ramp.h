// The travel over which the base-joint friction goes over to the other side after a reversal
// of a joint's swing ([Joint patent] figs. 10–12; the ramp λ of analysis/hexapod/joint_swing.h),
// from the servo loads once the masses and friction are identified (docs/methods.md §12). Each
// base joint carries a friction direction state r_j on the unit disk normal to its strut
// (StepSwingState: it moves by 2δ/λ with the joint's swing δ of each sample; a closed record from
// its steady state), and its force −(f_t,j/L_j) r_j ([PM-600 report] eqs. 3.11–3.12) is linear in
// r_j; λ minimises the residual of the strut forces over every sample where the tool tip moves
// and the strut's screw friction is settled — the samples the identification leaves out near
// reversals are the ones that see λ. A line search over log λ in [0.01, 20] mm; σ from the
// curvature of the residual.
#pragma once

#include <vector>

#include "analysis/hexapod/statics.h"
#include "analysis/servo/friction_states.h"
#include "analysis/servo/hexapod_motion.h"
#include "analysis/servo/load_model.h"
#include "analysis/servo/servo_types.h"

namespace km::servo {

struct RampEstimate {
  double ramp_mm = 0.0;
  double sigma_mm = 0.0;
  double residual_rms_N = 0.0;       // at the estimate, over the rows used
  double step_residual_rms_N = 0.0;  // with no ramp (λ → 0: r = unit(swing)), the same rows
  std::size_t rows = 0;
};

// `physics`: the identified machine. Throws km::NotObservable when no sample is usable.
RampEstimate EstimateJointRamp(const hexapod::HexapodGeometry& geometry,
                               const hexapod::MachinePhysics& physics,
                               const std::vector<ServoFile>& files, double min_rate_fraction,
                               double reversal_skip_mm);

// One record as the identification has prepared it: its motion, usable rows (TrackMotion,
// UsableRows), the θ-free parts of its model (PrepareSampleLoads with the machine `theta`
// below belongs to) and its friction path (PathOf).
struct RampRecord {
  const ServoFile* file = nullptr;
  const std::vector<MotionSample>* motion = nullptr;
  const std::vector<RowUse>* use = nullptr;
  const std::vector<SampleLoads>* loads = nullptr;
  const FrictionPath* path = nullptr;
};
// The same estimate with the identified parameters θ. Throws km::NotObservable as above.
RampEstimate EstimateJointRamp(const LoadVector& theta, const std::vector<RampRecord>& records);

}  // namespace km::servo
