// Synthetic DBB circular tests of a serial (3-axis) machine, for tests, demos and benchmarks.
//
// The machine position error is the sum of the registry effects (analysis/serial_effects, forward
// models e(θ) in the plane axes); the bar length is computed EXACTLY in 3-D,
//   bar = |C + R n(θ) + z_offset·normal + e(θ) − F|,   F = C + fixed-ball set-up offset,
// so the linearised radial signatures used by the diagnosis are tested against the exact
// geometry. Gaussian noise (seeded std::mt19937) is added to dr_um. Samples run in time order
// (angles decrease for cw) over one turn plus optional lead-in / lead-out arcs.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "analysis/dbb/dbb_types.h"
#include "analysis/serial_effects/registry.h"

namespace km::dbb {

struct SimEffect {
  serial_effects::EffectId id;
  std::vector<double> params;  // all parameters (linear then shape); shape defaults if short
};

struct SerialDbbSimOptions {
  std::string machine_id = "sim-serial";
  std::string test_id = "T1";
  Direction direction = Direction::kCcw;
  Plane plane = Plane::kXY;
  double radius_mm = 150.0;
  double bar_length_mm = 150.0;
  double z_offset_mm = 0.0;
  std::array<double, 3> centre_mm{0.0, 0.0, 0.0};
  double feed_mm_min = 1000.0;
  double step_deg = 0.1;
  double start_deg = 0.0;
  double lead_deg = 0.0;  // lead-in and lead-out arcs, each
  double noise_um = 0.1;
  std::uint32_t seed = 1;
  std::array<double, 2> fixed_ball_offset_um{0.0, 0.0};  // set-up error of the fixed ball
  bool absolute = false;  // write fixed_ball_mm (the true fixed-ball position) → absolute mode
  std::vector<SimEffect> effects;
};

DbbTest SimulateSerialDbbTest(const SerialDbbSimOptions& options);

// Total machine position error (µm, plane axes) of the effects at angle θ (rad).
std::array<double, 2> SimulatedPositionErrorUm(const SerialDbbSimOptions& options,
                                               double theta_rad);

}  // namespace km::dbb
