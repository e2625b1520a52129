#include "analysis/hexapod/effects/test_path.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "analysis/core/errors.h"
#include "analysis/hexapod/dbb_geometry.h"

namespace km::hexapod {
namespace {

TestPath PathOf(const HexapodGeometry& model, const MachinePhysics* physics, const dbb::DbbTest& t,
                double start_s) {
  if (!t.tool_length_mm)
    throw InvalidInput(t.test_id, 0, "tool_length_mm", "hexapod tests need the tool length");
  if (t.angle_deg.empty()) throw InvalidInput(t.test_id, 0, "samples", "the test has no samples");
  if (!(t.feed_mm_min > 0.0))
    throw InvalidInput(t.test_id, 0, "feed_mm_min", "must be positive for a hexapod test");
  TestPath p;
  p.test_id = t.test_id;
  p.direction = t.direction;
  p.tool_length_mm = *t.tool_length_mm;
  p.feed_mm_min = t.feed_mm_min;
  p.radius_mm = t.radius_mm;
  p.temperature_c = t.temperature_c;
  const std::size_t n = t.angle_deg.size();
  const double speed = t.feed_mm_min / 60.0;
  const double theta0 = t.angle_deg.front() * std::numbers::pi / 180.0;
  const bool gravity = physics && physics->has_gravity;
  for (std::size_t i = 0; i < n; ++i) {
    const double theta = t.angle_deg[i] * std::numbers::pi / 180.0;
    const Pose pose = CommandedDbbPose(t, theta);
    p.pose.push_back(pose);
    p.strut_mm.push_back(InverseKinematics(model, pose, p.tool_length_mm));
    p.time_s.push_back(start_s + t.radius_mm * std::abs(theta - theta0) / speed);
    p.frame.push_back(StrutFrameAt(model, pose, p.tool_length_mm));
    if (gravity) {
      p.gravity_N.push_back(GravityAxialForces(*physics, p.frame.back(), pose, p.tool_length_mm));
    }
  }
  return p;
}

}  // namespace

PreparedTests PrepareTests(const HexapodGeometry& model, const MachinePhysics* physics,
                           const std::vector<dbb::DbbTest>& tests,
                           const std::vector<std::optional<double>>& start_time_s) {
  PreparedTests out;
  out.setup.physics = physics;
  out.setup.all_timed = !tests.empty();
  out.setup.all_temperatures = !tests.empty();
  auto start_of = [&](std::size_t k) {
    return k < start_time_s.size() ? start_time_s[k] : std::optional<double>();
  };
  double t_ref = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < tests.size(); ++k) {
    out.setup.all_timed = out.setup.all_timed && start_of(k).has_value();
    out.setup.all_temperatures = out.setup.all_temperatures && tests[k].temperature_c.has_value();
    if (start_of(k)) t_ref = std::min(t_ref, *start_of(k));
  }
  double earliest = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < tests.size(); ++k) {
    const double start = start_of(k) ? *start_of(k) - t_ref : 0.0;
    out.paths.push_back(PathOf(model, physics, tests[k], start));
    out.paths.back().timed = start_of(k).has_value();
    const double l = *tests[k].tool_length_mm;
    auto& tools = out.setup.tool_lengths_mm;
    if (std::none_of(tools.begin(), tools.end(), [&](double x) { return std::abs(x - l) < 1e-9; }))
      tools.push_back(l);
    if (out.setup.all_temperatures && start < earliest) {
      earliest = start;
      out.setup.reference_temperature_c = *tests[k].temperature_c;
    }
  }
  std::sort(out.setup.tool_lengths_mm.begin(), out.setup.tool_lengths_mm.end());
  return out;
}

}  // namespace km::hexapod
