// The base-joint friction of [PM-600 report] eqs. 3.11–3.12 — one law for simulation,
// calibration, discovery and servo-load identification (docs/hexapod-effects.md
// § joint_friction).
//
//   N_c = −Σ_j (f_t,j / L_j) · v̂_j,   M_c = −Σ_j B_j × (f_t,j / L_j) · v̂_j,   f_t,j = t0 + t1·ĝ_j
//
// Reading adopted: v̂_j is the direction of the platform joint's motion *across* its strut,
// the part of d(L_j l_j)/dt normal to l_j, i.e. the direction of L_j dl_j/dt. Eq. 3.11 prints
// the whole d(L_j l_j)/dt, whose axial part L̇_j l_j is the strut's own extension; fig. 3.4
// draws the joint friction as a force normal to the strut, and a torque in the base joint can
// only produce a force normal to the strut at the platform joint (the axial friction is the
// ball screw's, eq. 3.10). So the force of one joint has the size f_t,j/L_j exactly, lies in
// the plane normal to its strut and opposes the strut's swing.
//
// Reversals: the friction direction is a state r in the plane normal to the strut, |r| ≤ 1.
// With a ramp λ > 0 ([Joint patent] fig. 11) it moves by 2δ/λ with the swing δ of the joint
// and is held to the unit disk, so after a reversal it passes linearly to the other side over a
// travel λ; λ = 0 is eq. 3.11 as printed (r = v̂). On a straight swing this is the 1-D ramp;
// on a turning swing with λ → 0 it is exactly v̂.
#pragma once

#include <Eigen/Core>

namespace km::hexapod {

// The part of a platform joint's displacement (or velocity) d across the strut l (unit).
inline Eigen::Vector3d SwingOf(const Eigen::Vector3d& l, const Eigen::Vector3d& d) {
  return d - d.dot(l) * l;
}

// One step of the friction direction state: `state` from the previous sample, `l` the strut
// direction now, `swing` the joint's swing since the previous sample (SwingOf), `ramp_mm` λ.
inline Eigen::Vector3d StepSwingState(const Eigen::Vector3d& state, const Eigen::Vector3d& l,
                                      const Eigen::Vector3d& swing, double ramp_mm) {
  Eigen::Vector3d r = state - state.dot(l) * l;  // the strut turned a little: stay normal
  const double size = swing.norm();
  if (!(ramp_mm > 0.0)) return size > 0.0 ? Eigen::Vector3d(swing / size) : r;
  r += (2.0 / ramp_mm) * swing;
  const double n = r.norm();
  if (n > 1.0) r /= n;
  return r;
}

// Friction torque of one base joint (N·m), eq. 3.12: t0 + t1·|ĝ_j| with ĝ_j the axial gravity
// force of the strut (N). The load on the joint's bearings is the size of the force: a strut
// pushed by the platform (compression at some tilts) loads its joint as a pulled one does. (On
// a hanging platform, where every strut is in tension, this is the report's t0 + t1·ĝ_j.)
// A negative sum (t1 < 0 under a large load) is no torque.
inline double JointFrictionTorque(double t0_Nm, double t1_m, double gravity_N) {
  const double t = t0_Nm + t1_m * (gravity_N < 0.0 ? -gravity_N : gravity_N);
  return t > 0.0 ? t : 0.0;
}

}  // namespace km::hexapod
