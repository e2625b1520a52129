// Rotational resistance of each leg's passive joints from the loads of CW and CCW circles at
// the same poses, and joint health ([Joint patent] formulas 21–28 and its diagnosis;
// docs/methods.md §13). At the same pose gravity and the (centripetal) inertia are the same in
// both directions while friction changes sign, so the difference of the strut loads,
// F_cw − F_ccw, holds friction alone (formulas 27–28). Per leg j it is modelled as
//   - the ball-screw friction f0_j along the strut (eq. 3.10 of [PM-600 report]),
//   - the base joint's resistance τb_j (N·m) against its swing, as one force
//     −(τb_j/L_j)·unit(L_j dl_j/dt) at the platform joint, normal to the strut ([PM-600 report]
//     eqs. 3.11–3.12, analysis/hexapod/joint_swing.h),
//   - the platform joint's resistance τp_j (N·m) against the strut's rotation relative to the
//     platform: the same force and, in addition, a moment τp_j·(l_j × unit(L_j dl_j/dt)) on the
//     platform (circles at a constant tilt: the platform does not turn),
// stacked over every matched pair of samples and solved by least squares (formulas 21–26)
// with the identifiability report of linear_lsq.h. A leg's resistance is τb_j + τp_j, at the
// mean load of the poses used: when the machine's friction model makes the resistance grow
// with the strut load (t0 + t1·ĝ_j, [PM-600 report] eq. 3.12, ĝ_j tension positive), each
// pose's regressor is scaled by that model's value there over its mean.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "analysis/hexapod/statics.h"
#include "analysis/servo/servo_types.h"

namespace km::servo {

struct JointOptions {
  double min_rate_fraction = 0.2;  // as IdentifyOptions
  double reversal_skip_mm = 1.0;
  double match_mm = 0.5;  // a CW and a CCW sample pair up when their poses are this close
  double min_singular_ratio = 1e-4;
  bool separate_platform_joints = true;  // try to tell base and platform joints apart
  // Levels: 2 above level2_ratio ×, 3 above level3_ratio × the reference resistance; with a
  // previous estimate, 2 when it grew by more than increase_warn (fraction), 3 by more than
  // increase_stop, each only when the growth is above 3 σ.
  double level2_ratio = 1.5;
  double level3_ratio = 2.5;
  double increase_warn = 0.3;
  double increase_stop = 1.0;
  // Reference resistance per leg (N·m); unset: the machine's t0 + t1·mean ĝ_j over the poses
  // used, or, without a friction model, the median of the six legs.
  std::optional<std::array<double, 6>> reference_Nm;
  // The previous estimate of the same machine, per leg (N·m).
  std::optional<std::array<double, 6>> previous_Nm;
  void Check() const;
};

struct JointValue {
  std::string joint;  // "base" or "platform"
  double resistance_Nm = 0.0;
  double sigma_Nm = 0.0;
  bool identified = true;  // false: held at 0, the data cannot tell it from the other joint
};

struct LegHealth {
  int leg = 0;  // 1–6
  double resistance_Nm = 0.0;
  double sigma_Nm = 0.0;
  double reference_Nm = 0.0;
  double ratio = 0.0;  // resistance / reference
  std::optional<double> previous_Nm;
  int level = 1;
  std::string evidence;
  std::array<JointValue, 2> joints;  // base, platform
  bool split_requested = true;       // JointOptions::separate_platform_joints
  double screw_friction_N = 0.0;
  double screw_friction_sigma_N = 0.0;
};

struct JointsResult {
  std::array<LegHealth, 6> legs;
  int level = 1;                   // the worst
  std::string reference_source;    // "machine model", "given", "median of the legs"
  std::vector<std::string> pairs;  // test ids used
  std::size_t rows = 0;
  double residual_rms_N = 0.0;
  double condition_number = 0.0;
  std::vector<std::string> not_identifiable;
};

JointsResult EstimateJointResistance(const hexapod::HexapodGeometry& geometry,
                                     const hexapod::MachinePhysics& machine,
                                     const std::vector<ServoFile>& files,
                                     const JointOptions& options = {});

// Level of one leg from its estimate and the options' limits (used by EstimateJointResistance);
// writes the evidence.
void GradeLeg(LegHealth& leg, const JointOptions& options);

}  // namespace km::servo
