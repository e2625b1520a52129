#include "analysis/sim/hexapod_dbb_sim.h"

#include <cmath>
#include <numbers>
#include <random>

#include "analysis/core/errors.h"
#include "analysis/hexapod/dbb_geometry.h"
#include "analysis/hexapod/effects/test_path.h"

namespace km::sim {

namespace {

constexpr double kPi = std::numbers::pi;

struct PlanRow {
  const char* id;
  int hole;   // 1–8 on the ring, 9 = jig centre
  int level;  // platform height 1 (lowest) – 3 (highest)
  double a_deg, b_deg, c_deg;
};

// [PM-600 report] table 2.1 (hole × level), with tilts added on some rows.
constexpr PlanRow kTable21[] = {
    {"a", 9, 1, 0, 0, 0},   {"b", 4, 1, 0, 0, 0},   {"c", 6, 1, 0, 0, 0},   {"d", 8, 1, 0, 0, 0},
    {"e", 2, 1, 0, 0, 0},   {"f", 9, 2, 0, 0, 0},   {"g", 3, 2, 15, 0, 0},  {"h", 5, 2, 0, 15, 0},
    {"i", 7, 2, -15, 0, 0}, {"j", 1, 2, 0, -15, 0}, {"k", 9, 3, 10, 10, 0}, {"l", 4, 3, 0, 0, 0},
    {"m", 6, 3, -10, 0, 0}, {"n", 8, 3, 0, -10, 0}, {"o", 2, 3, 0, 0, 0},
};

Eigen::Vector3d JigHole(int hole, int level) {
  constexpr double kRingMm = 100.0;
  const double z = -1250.0 + 100.0 * level;  // levels 1..3 → −1150, −1050, −950
  if (hole == 9) return {0.0, 0.0, z};
  const double phi = (hole - 1) * kPi / 4.0;
  auto snap = [](double v) { return std::abs(v) < 1e-9 ? 0.0 : v; };  // exact zeros on the axes
  return {snap(kRingMm * std::cos(phi)), snap(kRingMm * std::sin(phi)), z};
}

HexapodDbbSpec SpecFromRow(const PlanRow& row, int samples_per_turn) {
  HexapodDbbSpec s;
  s.test_id = row.id;
  s.centre_mm = JigHole(row.hole, row.level);
  s.tilt_deg = Eigen::Vector3d(row.a_deg, row.b_deg, row.c_deg);
  if (row.level == 2) {  // cone test ([PM-600 report] §4.2.4): R 144, bar 150, 42 mm offset
    s.radius_mm = 144.0;
    s.bar_length_mm = 150.0;
    s.z_offset_mm = 42.0;
  }
  s.samples_per_turn = samples_per_turn;
  return s;
}

dbb::DbbTest HeaderOf(const HexapodDbbSpec& spec, const std::string& machine_id) {
  dbb::DbbTest t;
  t.machine_id = machine_id;
  t.test_id = spec.test_id;
  t.direction = spec.direction;
  t.plane = spec.plane;
  t.bar_length_mm = spec.bar_length_mm;
  t.radius_mm = spec.radius_mm;
  t.centre_mm = {spec.centre_mm.x(), spec.centre_mm.y(), spec.centre_mm.z()};
  t.z_offset_mm = spec.z_offset_mm;
  t.feed_mm_min = spec.feed_mm_min;
  t.tilt_deg = {spec.tilt_deg.x(), spec.tilt_deg.y(), spec.tilt_deg.z()};
  t.tool_length_mm = spec.tool_length_mm;
  t.timestamp = spec.timestamp;
  return t;
}

}  // namespace

std::vector<HexapodDbbSpec> Table21Plan(int samples_per_turn, bool both_directions) {
  std::vector<HexapodDbbSpec> plan;
  for (const auto& row : kTable21) {
    auto s = SpecFromRow(row, samples_per_turn);
    plan.push_back(s);
    if (both_directions) {
      s.direction = dbb::Direction::kCw;
      plan.push_back(s);
    }
  }
  return plan;
}

std::vector<HexapodDbbSpec> VerificationPlan(int samples_per_turn) {
  // [PM-600 report] table 2.2 positions a, d, f, h, j, k, l, n — here flat and untilted.
  std::vector<HexapodDbbSpec> plan;
  for (const auto& row : kTable21) {
    const std::string id = row.id;
    if (id != "a" && id != "d" && id != "f" && id != "h" && id != "j" && id != "k" && id != "l" &&
        id != "n") {
      continue;
    }
    HexapodDbbSpec s;
    s.test_id = id;
    s.centre_mm = JigHole(row.hole, row.level);
    s.samples_per_turn = samples_per_turn;
    plan.push_back(s);
  }
  return plan;
}

dbb::DbbTest SimulateHexapodDbb(const hexapod::HexapodGeometry& controller,
                                const hexapod::HexapodGeometry& truth, const HexapodDbbSpec& spec,
                                const HexapodDbbSimOptions& options, std::uint32_t rng_seed,
                                const hexapod::Perturbation* effects) {
  if (!(options.noise_um >= 0.0) || !(options.fixed_ball_error_um >= 0.0)) {
    throw InvalidInput("", 0, "noise_um", "noise levels must not be negative");
  }
  if (spec.samples_per_turn < 8) {
    throw InvalidInput("", 0, "samples_per_turn", "needs at least 8 samples per turn");
  }
  if (!(spec.bar_length_mm > 0.0) || !(spec.radius_mm > 0.0) || !(spec.tool_length_mm >= 0.0)) {
    throw InvalidInput("", 0, "bar_length_mm", "bar length and radius must be positive");
  }
  dbb::DbbTest test = HeaderOf(spec, options.machine_id);
  const double l = spec.tool_length_mm;
  const auto axes = hexapod::DbbPlaneAxes(spec.plane);

  std::mt19937 rng(rng_seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  // Fixed ball.
  Eigen::Vector3d F = spec.centre_mm;
  if (options.absolute) {
    test.fixed_ball_mm = test.centre_mm;
    if (options.fixed_ball_error_um > 0.0) {
      const Eigen::Vector3d e(unit(rng), unit(rng), unit(rng));
      F += 1e-3 * options.fixed_ball_error_um * e;
    }
  } else {
    hexapod::Pose centre_pose;
    centre_pose.tip_mm = spec.centre_mm + spec.z_offset_mm * axes[2];
    centre_pose.abc_rad = spec.tilt_deg * (kPi / 180.0);
    const auto s = hexapod::InverseKinematics(controller, centre_pose, l);
    const auto real = hexapod::ForwardKinematics(truth, s, l, centre_pose);
    F = real.pose.tip_mm - spec.z_offset_mm * axes[2];
  }

  std::normal_distribution<double> noise(0.0, options.noise_um);
  const int n = spec.samples_per_turn;
  const double sign = spec.direction == dbb::Direction::kCw ? -1.0 : 1.0;
  test.angle_deg.reserve(n + 1);
  test.dr_um.reserve(n + 1);
  hexapod::Pose guess;
  for (int k = 0; k <= n; ++k) {  // k = n closes the turn (360°)
    const double angle_deg = sign * 360.0 * k / n;
    const double angle_rad = angle_deg * kPi / 180.0;
    const hexapod::Pose cmd = hexapod::CommandedDbbPose(test, angle_rad);
    hexapod::Vector6d s = hexapod::InverseKinematics(controller, cmd, l);
    if (options.extra_strut_error)
      s += options.extra_strut_error(cmd, s, angle_rad, spec.direction);
    double l_real = l;
    if (effects) {
      s += effects->ds_mm[static_cast<std::size_t>(k)];
      l_real += effects->dl_mm[static_cast<std::size_t>(k)];
    }
    const auto real = hexapod::ForwardKinematics(truth, s, l_real, cmd);
    const double bar = (real.pose.tip_mm - F).norm();
    double dr = 1000.0 * (bar - spec.bar_length_mm);
    if (options.noise_um > 0.0) dr += noise(rng);
    test.angle_deg.push_back(angle_deg);
    test.dr_um.push_back(dr);
  }
  return test;
}

std::vector<dbb::DbbTest> SimulateHexapodDbbPlan(const hexapod::HexapodGeometry& controller,
                                                 const hexapod::HexapodGeometry& truth,
                                                 const std::vector<HexapodDbbSpec>& plan,
                                                 const HexapodDbbSimOptions& options) {
  std::vector<dbb::DbbTest> out;
  out.reserve(plan.size());
  std::vector<hexapod::Perturbation> pert(plan.size());
  if (!options.effects.empty()) {
    // The commanded motion of every test (header and angles), then the effects over the plan.
    std::vector<dbb::DbbTest> motion;
    std::vector<std::optional<double>> starts;
    for (const auto& spec : plan) {
      dbb::DbbTest t = HeaderOf(spec, options.machine_id);
      const double sign = spec.direction == dbb::Direction::kCw ? -1.0 : 1.0;
      for (int k = 0; k <= spec.samples_per_turn; ++k) {
        t.angle_deg.push_back(sign * 360.0 * k / spec.samples_per_turn);
        t.dr_um.push_back(0.0);
      }
      motion.push_back(std::move(t));
      starts.push_back(spec.start_time_s);
    }
    const auto prepared = hexapod::PrepareTests(controller, options.physics, motion, starts);
    for (std::size_t i = 0; i < plan.size(); ++i)
      hexapod::ApplyEffects(options.effects, prepared.paths[i], prepared.setup, pert[i]);
  }
  for (std::size_t i = 0; i < plan.size(); ++i) {
    out.push_back(SimulateHexapodDbb(controller, truth, plan[i], options,
                                     options.seed + 7919u * static_cast<std::uint32_t>(i),
                                     options.effects.empty() ? nullptr : &pert[i]));
  }
  return out;
}

hexapod::HexapodGeometry PerturbGeometry(const hexapod::HexapodGeometry& nominal, double base_mm,
                                         double strut_mm, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  hexapod::HexapodGeometry g = nominal;
  for (auto& q : g.base_joints_mm) {
    for (int c = 0; c < 3; ++c) q[c] += base_mm * u(rng);
  }
  for (auto& o : g.strut_offset_mm) o += strut_mm * u(rng);
  return g;
}

}  // namespace km::sim
