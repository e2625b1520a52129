// Synthetic DBB circular tests on a hexapod with known true parameters ([PM-600 report] §2.3).
//
// For every sample the controller commands the strut lengths of its own model (normally the
// nominal machine file): s = IK_ctrl(T(θ)) with T(θ) the commanded tool pose of the test (see
// analysis/hexapod/dbb_geometry.h). The real machine realises those lengths with its TRUE
// parameters, plus optional extra strut-length errors from a hook (gravity, friction, …):
//
//   T_real(θ) = FK_true(s + e(θ)),   bar(θ) = |tip(T_real(θ)) − F| ,   dr_um = 1000·(bar − R_DBB) +
//   noise
//
// Fixed ball F:
//  * absolute (jig) set-up: F = the jig position given in the plan = the commanded centre
//    (the file then carries fixed_ball_mm = that position; the real ball may sit off it by a
//    seeded Gaussian seating error, HexapodDbbSimOptions::fixed_ball_error_um);
//  * conventional set-up: the spindle is commanded to the circle centre (moving-ball plane) and
//    the fixed ball is seated where the real tool tip stands, shifted down by z_offset along
//    the plane normal: F = tip(FK_true(IK_ctrl(c + z_offset·n))) − z_offset·n.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/dbb/dbb_types.h"
#include "analysis/hexapod/effects/registry.h"
#include "analysis/hexapod/kinematics.h"

namespace km::sim {

struct HexapodDbbSpec {
  std::string test_id;
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();  // commanded centre = jig ball position
  Eigen::Vector3d tilt_deg = Eigen::Vector3d::Zero();   // A, B, C
  double tool_length_mm = 100.0;
  double radius_mm = 150.0;
  double bar_length_mm = 150.0;
  double z_offset_mm = 0.0;  // moving-ball plane minus fixed-ball height (cone: 42)
  dbb::Direction direction = dbb::Direction::kCcw;
  dbb::Plane plane = dbb::Plane::kXY;
  int samples_per_turn = 720;
  double feed_mm_min = 1000.0;
  std::optional<double> start_time_s;    // on any common scale (effects that depend on time)
  std::optional<std::string> timestamp;  // written to the file
};

// Extra strut-length error (mm, added to the realised joint-to-joint length) for one sample:
// commanded pose, commanded strut values, commanded angle (rad) and direction of the test.
using StrutErrorHook = std::function<hexapod::Vector6d(const hexapod::Pose& commanded,
                                                       const hexapod::Vector6d& strut_command_mm,
                                                       double angle_rad, dbb::Direction direction)>;

struct HexapodDbbSimOptions {
  bool absolute = true;   // jig set-up (fixed_ball_mm written) or conventional set-up
  double noise_um = 0.0;  // σ of white Gaussian noise added to every dr sample
  // Jig set-up only: σ (per coordinate) of the difference between where the fixed ball really
  // sits and the position written to the file ([PM-600 report] §2.3.2: re-seating repeatability
  // 1.0 µm short / 3.2 µm long support unit).
  double fixed_ball_error_um = 0.0;
  std::uint32_t seed = 1;
  std::string machine_id = "pm600-like";
  StrutErrorHook extra_strut_error;  // optional
  // Hexapod effects of the real machine (analysis/hexapod/effects), evaluated on the commanded
  // motion of the whole plan (times from the specs' start_time_s). Needs `physics` for the
  // effects that use masses and compliance.
  std::vector<hexapod::ActiveEffect> effects;
  const hexapod::MachinePhysics* physics = nullptr;
};

// The 15 calibration tests shaped like [PM-600 report] table 2.1: jig holes (9 = centre, 1–8 on a
// 100 mm ring every 45°) × platform height levels 1–3 (fixed-ball z = −1150, −1050, −950 mm).
// Level 2 tests are cone tests (R 144, bar 150, z offset 42) and some tests are tilted
// (|A|, |B| ≤ 15°) so that every kinematic parameter is seen. Both directions when asked.
std::vector<HexapodDbbSpec> Table21Plan(int samples_per_turn = 720, bool both_directions = true);

// 8 verification positions on the jig (flat, untilted; shape of [PM-600 report] table 2.2).
std::vector<HexapodDbbSpec> VerificationPlan(int samples_per_turn = 720);

// One simulated test. `rng_seed` seeds the noise of this test only; `effects` (optional) are
// the effects' strut- and tool-length changes for every sample (samples_per_turn + 1 of them).
dbb::DbbTest SimulateHexapodDbb(const hexapod::HexapodGeometry& controller,
                                const hexapod::HexapodGeometry& truth, const HexapodDbbSpec& spec,
                                const HexapodDbbSimOptions& options, std::uint32_t rng_seed,
                                const hexapod::Perturbation* effects = nullptr);

// All tests of a plan; test i uses noise seed options.seed + 7919·i.
std::vector<dbb::DbbTest> SimulateHexapodDbbPlan(const hexapod::HexapodGeometry& controller,
                                                 const hexapod::HexapodGeometry& truth,
                                                 const std::vector<HexapodDbbSpec>& plan,
                                                 const HexapodDbbSimOptions& options);

// A "real machine": base joints moved uniformly within ±base_mm per coordinate, strut offsets
// changed uniformly within ±strut_mm. Seeded.
hexapod::HexapodGeometry PerturbGeometry(const hexapod::HexapodGeometry& nominal, double base_mm,
                                         double strut_mm, std::uint32_t seed);

}  // namespace km::sim
